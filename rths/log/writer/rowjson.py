"""Log messages as JSON bytes: row blocks, mappings with non-finite numbers, open schemas.

The writer (:mod:`rths.log.writer.mcap_writer`) and the live view (:mod:`rths.log.live`) write the
same bytes: a row of a :class:`rths.core.channels.RowBlock` becomes ``{"seq": k, <channel>: value,
...}`` (:func:`block_messages`); a NaN or infinity becomes ``null`` (JSON has none).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import orjson

__all__ = ["LENIENT", "STRICT", "block_json", "block_messages", "finite", "open_schema"]


def open_schema(topic: str) -> bytes:
    """Schema for a topic first seen from another process: any JSON object.

    Parameters
    ----------
    topic : str
        The topic's name (the schema's title).
    """
    return json.dumps(
        {"title": topic, "type": "object", "description": "log record from another process"}
    ).encode()


def _plain(obj: Any) -> Any:
    """``json.dumps`` fallback: numpy scalars and arrays become Python numbers and lists."""
    if hasattr(obj, "tolist"):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def finite(obj: Any) -> Any:
    """``obj`` with every NaN/infinite float replaced by None (JSON has no NaN).

    Parameters
    ----------
    obj
        A number, a mapping, a list/tuple or a numpy value, nested as JSON allows.
    """
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    if hasattr(obj, "tolist"):
        return finite(obj.tolist())
    return obj


# One encoder each, built once: json.dumps(**options) would build a new one per message.
STRICT = json.JSONEncoder(allow_nan=False, separators=(",", ":"), default=_plain)
LENIENT = json.JSONEncoder(separators=(",", ":"), default=_plain)


def _template(names: tuple[str, ...], templates: dict[tuple[str, ...], bytes] | None) -> bytes:
    """``b'{"seq":%d,"<name>":%s,...}'`` for a block's channel names (cached in ``templates``)."""
    cache = {} if templates is None else templates
    template = cache.get(names)
    if template is None:
        fields = "".join(f',"{name}":%s' for name in names)
        template = cache[names] = ('{"seq":%d' + fields + "}").encode()
    return template


def block_json(
    block: Any, templates: dict[tuple[str, ...], bytes] | None = None
) -> tuple[list[bytes], int]:
    """The filled rows of a :class:`rths.core.channels.RowBlock` as JSON messages.

    Each row is ``{"seq": k, <channel>: value, ...}``.  The numbers of the whole block are
    formatted by one ``orjson`` call (shortest round-trip form, ``null`` for a non-finite value,
    as JSON has none) and put into a template of the block's channel names: about 3 µs per row
    of 20 channels, where formatting each float with ``repr`` took 20 µs.

    Parameters
    ----------
    block
        A :class:`rths.core.channels.RowBlock`.
    templates
        Cache of templates, keyed by the block's channel names (shared across calls).

    Returns
    -------
    messages : list of bytes
        One per filled row.
    nonfinite : int
        How many of those rows hold a NaN or an infinity (written as ``null``).
    """
    import numpy as np

    n = block.count
    if not n:
        return [], 0
    template = _template(block.names, templates)
    values = block.values[:n]
    nonfinite = n - int(np.isfinite(values).all(axis=1).sum())
    seqs = block.seq[:n].tolist()
    if not block.names:
        return [template % k for k in seqs], nonfinite
    # "[[a,b,...],[c,d,...],...]" -> one b"a,b,..." per row (numbers hold no "]" or ",")
    rows = orjson.dumps(np.ascontiguousarray(values), option=orjson.OPT_SERIALIZE_NUMPY)
    return [
        template % (k, *numbers.split(b",")) for k, numbers in zip(seqs, rows[2:-2].split(b"],["))
    ], nonfinite


def block_messages(
    block: Any, templates: dict[tuple[str, ...], bytes] | None = None
) -> list[tuple[int, int, bytes, bool]]:
    """The rows of a :class:`rths.core.channels.RowBlock` as JSON messages.

    Each row is ``{"seq": k, <channel>: value, ...}`` (:func:`block_json`).

    Parameters
    ----------
    block
        A :class:`rths.core.channels.RowBlock`.
    templates
        Cache of templates, keyed by the block's channel names (shared across calls).

    Returns
    -------
    list of tuple
        ``(seq, log_time_ns, json_bytes, finite)`` per filled row.
    """
    import numpy as np

    n = block.count
    data, _ = block_json(block, templates)
    finite = np.isfinite(block.values[:n]).all(axis=1).tolist()
    return list(zip(block.seq[:n].tolist(), block.t_ns[:n].tolist(), data, finite))
