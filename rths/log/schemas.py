"""Topics and their JSON schemas: the log contract's message shapes (design.md §4).

Every MCAP channel of a log carries UTF-8 JSON described by a ``jsonschema`` schema with units:
``rths/loop`` (:data:`LOOP_SCHEMA`, one record per loop step), ``rths/events``
(:data:`EVENTS_SCHEMA`), and one schema per row-block topic generated from the block's channel
declarations (:func:`block_schema`).  :func:`object_schema` builds the flat ones.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from rths.core.channels import RowBlock, json_schema
from rths.core.errors import ParameterError

__all__ = [
    "EVENTS_SCHEMA",
    "EVENTS_TOPIC",
    "LOOP_SCHEMA",
    "LOOP_TOPIC",
    "block_schema",
    "check_metadata",
    "object_schema",
]

LOOP_TOPIC = "rths/loop"
EVENTS_TOPIC = "rths/events"


def object_schema(
    title: str,
    fields: Mapping[str, str],
    *,
    required: Sequence[str] | None = None,
    description: str = "",
) -> dict[str, Any]:
    """A JSON schema for a flat object of numbers, one description (with unit) per field.

    Parameters
    ----------
    title
        Schema name, e.g. ``"rths.timing"``.
    fields
        ``{field: "description [unit]"}``; every field is a number (or ``null`` for non-finite).
    required
        Fields that must be present (default: all of them).
    description
        What one message is.
    """
    if not fields:
        raise ParameterError(f"schema {title!r} needs at least one field; got {dict(fields)!r}")
    req = list(fields) if required is None else list(required)
    unknown = [name for name in req if name not in fields]
    if unknown:
        raise ParameterError(f"required fields of schema {title!r} are not fields: {unknown!r}")
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": {
            name: {"type": ["number", "null"], "description": text} for name, text in fields.items()
        },
        "required": req,
    }


#: Schema of ``rths/loop``: one message per loop step at the interface, specimen scale.
LOOP_SCHEMA: dict[str, Any] = object_schema(
    "rths.loop",
    {
        "t": "simulated time at the end of the step, t_(k+1) = (k+1) dt [s]",
        "target": "target displacement of the specimen end from the numerical substructure [m]",
        "command": "actuator command held over the step, after compensation [m]",
        "measured": "measured displacement of the specimen end [m]",
        "force": "measured restoring force of the specimen [N]",
    },
    description="One RTHS loop step at the interface (specimen scale); Message.sequence = k.",
)


def block_schema(topic: str, block: RowBlock, description: str = "") -> dict[str, Any]:
    """The JSON schema of a topic whose messages are the rows of ``block``.

    Parameters
    ----------
    topic
        The MCAP topic (the title is the topic with ``/`` as ``.``).
    block
        A block with the topic's channel declarations (its rows are not read).
    description
        What one message is (default: one row per step).
    """
    return json_schema(
        topic.replace("/", "."),
        block.channels,
        description=description or f"one row per step of {topic}; Message.sequence = seq",
        seq=True,
    )


#: Schema of ``rths/events``.
EVENTS_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "rths.events",
    "description": "Run events: start, stop, overrun, gap (a skipped sequence number), error.",
    "type": "object",
    "properties": {
        "kind": {"type": "string", "description": "event kind, e.g. 'gap', 'overrun', 'error'"},
        "message": {"type": "string", "description": "human-readable description"},
    },
    "required": ["kind", "message"],
}


def check_metadata(metadata: Mapping[str, Mapping[str, str]]) -> dict[str, dict[str, str]]:
    """A checked copy of MCAP metadata records.

    Parameters
    ----------
    metadata
        ``{record name: {key: value}}``, all strings.

    Raises
    ------
    ParameterError
        Naming the first name, key or value that is not a string.
    """
    checked: dict[str, dict[str, str]] = {}
    for name, record in metadata.items():
        if not isinstance(name, str) or not isinstance(record, Mapping):
            raise ParameterError(
                f"metadata must map record names to {{key: value}} dicts; got {name!r}: {record!r}"
            )
        for key, value in record.items():
            if not isinstance(key, str) or not isinstance(value, str):
                raise ParameterError(
                    f"metadata[{name!r}] keys and values must be strings; got {key!r}: {value!r}"
                )
        checked[name] = dict(record)
    return checked
