"""A checker of JSON documents against the subset of JSON Schema (draft 2020-12) that
``results.schema.json`` uses, so that reading results needs no schema library.

Supported keywords: ``type`` (a name or a list of names), ``enum``, ``minimum``, ``maximum``,
``required``, ``properties``, ``additionalProperties`` (false or a schema), ``items`` (one
schema for every item) and ``$ref`` to ``#/$defs/NAME``; ``$schema``, ``$id``, ``title`` and
``description`` are annotations. A schema with any other keyword is refused (ValueError), so
that a schema that grows a keyword cannot be checked silently in part. The test suite holds
this checker against the ``jsonschema`` package on valid and broken documents.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping


_ANNOTATIONS = {"$schema", "$id", "title", "description", "$defs"}
_KEYWORDS = {"type", "enum", "minimum", "maximum", "required", "properties", "additionalProperties", "items",
             "$ref"}


def _is_type(value, name: str) -> bool:
    if name == "object":
        return isinstance(value, Mapping)
    if name == "array":
        return isinstance(value, list)
    if name == "string":
        return isinstance(value, str)
    if name == "boolean":
        return isinstance(value, bool)
    if name == "null":
        return value is None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if name == "number":
        return True
    if name == "integer":
        return isinstance(value, int) or (math.isfinite(value) and float(value).is_integer())
    raise ValueError(f"schema type {name!r} is not supported")


def _errors(value, schema: Mapping, root: Mapping, path: tuple) -> Iterator[tuple[tuple, str]]:
    unknown = set(schema) - _KEYWORDS - _ANNOTATIONS
    if unknown:
        raise ValueError(f"schema keywords {sorted(unknown)} are not supported by vibupdate's checker")
    if "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/$defs/"):
            raise ValueError(f"schema reference {ref!r} is not supported (only #/$defs/NAME)")
        yield from _errors(value, root["$defs"][ref[len("#/$defs/"):]], root, path)
    if "type" in schema:
        names = [schema["type"]] if isinstance(schema["type"], str) else list(schema["type"])
        if not any(_is_type(value, n) for n in names):
            yield path, f"{value!r} is not of type {', '.join(repr(n) for n in names)}"
            return
    if "enum" in schema and value not in schema["enum"]:
        yield path, f"{value!r} is not one of {schema['enum']!r}"
    if _is_type(value, "number"):
        if "minimum" in schema and value < schema["minimum"]:
            yield path, f"{value!r} is less than the minimum of {schema['minimum']!r}"
        if "maximum" in schema and value > schema["maximum"]:
            yield path, f"{value!r} is greater than the maximum of {schema['maximum']!r}"
    if isinstance(value, Mapping):
        for key in schema.get("required", ()):
            if key not in value:
                yield path, f"{key!r} is a required property"
        properties = schema.get("properties", {})
        extra = schema.get("additionalProperties", True)
        for key, item in value.items():
            if key in properties:
                yield from _errors(item, properties[key], root, path + (key,))
            elif extra is False:
                yield path, f"additional property {key!r} is not allowed"
            elif isinstance(extra, Mapping):
                yield from _errors(item, extra, root, path + (key,))
    if isinstance(value, list) and "items" in schema:
        for k, item in enumerate(value):
            yield from _errors(item, schema["items"], root, path + (k,))


def first_error(document, schema: Mapping) -> tuple[tuple, str] | None:
    """The first place where ``document`` breaks ``schema``: ``(path, message)``, the path a
    tuple of keys and item indices from the top; None when the document matches."""
    return next(_errors(document, schema, schema, ()), None)
