"""``rths kinds [FAMILY] [--markdown]``: the registered kinds of each family and their options.

This is the reference of what a scenario's ``[substructure]``, ``[specimen]``, ``[actuator]`` and
``[compensator]`` tables accept, read from the registries (:mod:`rths.core.registry`); the
README's table of kinds is its ``--markdown`` output (a test keeps the two identical).
"""

from __future__ import annotations

import argparse

__all__ = ["add_parser", "describe", "run"]

_FAMILIES = ("substructure", "specimen", "actuator", "compensator")


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths kinds``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "kinds",
        help="list the kinds a scenario can name, with their options",
        description="List the registered substructure, specimen, actuator and compensator kinds "
        "with the keys their scenario table takes (type, default, meaning).",
    )
    p.add_argument("family", nargs="?", choices=_FAMILIES, help="only this family")
    p.add_argument("--markdown", action="store_true", help="Markdown tables (the README's)")
    return p


def describe(families: tuple[str, ...] = _FAMILIES, markdown: bool = False) -> str:
    """The text ``rths kinds`` prints.

    Parameters
    ----------
    families : tuple of str
        Families to list, of ``"substructure"``, ``"specimen"``, ``"actuator"`` and
        ``"compensator"`` (default: all four, in that order).
    markdown : bool
        True: one Markdown table per family (kind, summary, option keys with defaults), the
        README's table of kinds; False (default): plain text with every option's type, default
        and meaning.
    """
    from rths.config.kinds import registry
    from rths.config.options import describe_options

    out: list[str] = []
    for family in families:
        kinds = registry(family)
        if markdown:
            out += [f"**[{family}]**", "", "| kind | what | options (default) |", "|---|---|---|"]
        else:
            out += [f"[{family}]"]
        for kind in kinds:
            options = describe_options(kind.options)
            if markdown:
                keys = ", ".join(
                    f"`{o.key}`" + ("" if o.default is None else f" ({o.default})") for o in options
                )
                out.append(f"| `{kind.name}` | {kind.summary} | {keys or '--'} |")
                continue
            out.append(f"  {kind.name:<18} {kind.summary}  ({kind.module})")
            for o in options:
                default = "required" if o.default is None else f"default {o.default}"
                out.append(
                    f"      {o.key:<22} {o.type}; {default}"
                    + (f" -- {o.description}" if o.description else "")
                )
        out.append("")
    return "\n".join(out).rstrip() + "\n"


def run(args: argparse.Namespace) -> int:
    """Print the kinds.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths kinds`` (the options :func:`add_parser`
        declares).
    """
    families = _FAMILIES if args.family is None else (args.family,)
    print(describe(families, args.markdown), end="")
    return 0
