"""The hostile-input corpus (``tests/bad_inputs``, issue 10): scenario files, NOMINAL.tomls, CSV
records, damaged MCAP logs and argument vectors a new user -- or a hostile one -- might give.

Every case must give exit code 2 and exactly one line on stderr that names the problem (the
manifest's regex), with no traceback and no warning before it; a refused command leaves nothing
behind (no log, no report folder).  The CLI runs in this process (``_cli.run_cli`` shows warnings
and thread exceptions on the captured stderr as a terminal would); ``tools/probe_inputs.py`` runs
the same corpus through the console script in subprocesses for the figure.
"""

from __future__ import annotations

import re
import tomllib

import pytest
from _cli import run_cli
from _corpus import CORPUS, Fixtures, argv, cases, make_fixtures

CASES = cases()


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory) -> Fixtures:
    folder = tmp_path_factory.mktemp("corpus")
    fx = make_fixtures(folder)
    log = folder / "good.mcap"
    result = run_cli(["run", str(fx.seed), "--clock", "fast", "--out", str(log), "--no-progress"])
    assert result.code == 0, result.err
    return Fixtures(fx.seed, fx.good_csv, log)


def test_the_corpus_lists_every_file_and_holds_over_a_hundred():
    listed = set(tomllib.loads((CORPUS / "cases.toml").read_text(encoding="utf-8")))
    files = {
        p.relative_to(CORPUS).as_posix()
        for p in CORPUS.rglob("*")
        if p.is_file() and p.name != "cases.toml"
    }
    assert files == listed
    assert len(files) >= 100 and len(CASES) >= len(files)
    kinds = {name.split("/")[0] for name in files}
    assert kinds == {"scenarios", "nominal", "csv", "mcap", "mcap_cut", "argv"}


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_one_line_and_exit_2(case, fixtures, tmp_path):
    result = run_cli(argv(case, fixtures, tmp_path))
    shown = f"exit {result.code}\nstderr:\n{result.err}\nstdout:\n{result.out[-500:]}"
    assert result.code == 2, shown
    assert len(result.err_lines) == 1 and "Traceback" not in result.err, shown
    line = result.err_lines[0]
    assert line.startswith("rths") and ": error: " in line, shown
    assert re.search(case.expect, line, re.IGNORECASE), shown
    assert not any(tmp_path.iterdir()), f"left behind: {sorted(tmp_path.iterdir())}"
