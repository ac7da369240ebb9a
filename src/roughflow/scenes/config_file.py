"""Checks of a workflow config: its file, and its loaded form against the schema.

PyYAML (and so Snakemake) keeps the last of two equal keys in one mapping without a word:
a study block given twice, or a ``seeds:`` repeated inside one, would silently drop the
first. :func:`check_config_file` refuses such a file, naming the key and both lines.
:func:`schema_error` words the schema's objection for a person: the key, a short form of
its value, and for an unknown key the known ones and the nearest.
"""

from __future__ import annotations

import difflib
import os
import re
from pathlib import Path

import yaml

from roughflow.errors import InputError


def duplicate_keys(node: yaml.Node | None) -> list[tuple[str, int, int]]:
    """(dotted key, first line, second line) of each key given twice in one mapping of a
    composed YAML node tree (aliases are followed once; merge keys ``<<`` may override)."""
    stack, seen, found = [(node, ())], set(), []
    while stack:
        node, path = stack.pop()
        if node is None or id(node) in seen:  # an alias: the anchored node was checked
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            lines: dict[tuple[str, str], int] = {}
            for key, value in node.value:
                if key.tag == "tag:yaml.org,2002:merge" or not isinstance(key, yaml.ScalarNode):
                    stack.append((value, path))
                    continue
                line = key.start_mark.line + 1
                if (key.tag, key.value) in lines:
                    found.append((".".join((*path, key.value)), lines[key.tag, key.value], line))
                lines.setdefault((key.tag, key.value), line)
                stack.append((value, (*path, key.value)))
        elif isinstance(node, yaml.SequenceNode):
            stack += [(item, (*path[:-1], f"{path[-1]}[{i}]") if path else (f"[{i}]",))
                      for i, item in enumerate(node.value)]
    return found


def check_config_file(path: str | os.PathLike) -> None:
    """Refuse a config file (YAML or JSON) that gives a key twice in one mapping. A file
    that cannot be read or parsed is left to the loader that reports it."""
    try:
        root = yaml.compose(Path(path).read_text(encoding="utf-8"), Loader=yaml.SafeLoader)
    except (OSError, yaml.YAMLError):
        return
    found = duplicate_keys(root)
    if found:
        name, first, second = min(found, key=lambda f: f[2])
        raise InputError(f"config file {str(path)!r}: key {name!r} is given twice (lines "
                         f"{first} and {second}); YAML would silently keep only the last one")


#: Values longer than this are shortened in messages (a misspelt study name dumped the
#: whole ``studies`` block).
SHOWN_VALUE = 80


def schema_error(config: dict, schema: dict) -> str | None:
    """The most relevant objection of the JSON ``schema`` to ``config`` as one sentence
    naming the key (jsonschema's best match), or None if it has none."""
    import jsonschema

    error = jsonschema.exceptions.best_match(
        jsonschema.Draft202012Validator(schema).iter_errors(config))
    if error is None:
        return None
    key = ".".join(str(p) for p in error.absolute_path)
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        known = sorted(error.schema.get("properties", {}))
        patterns = list(error.schema.get("patternProperties", {}))
        unknown = [k for k in error.instance if k not in known
                   and not any(re.search(p, str(k)) for p in patterns)]
        named = []
        for k in unknown:
            near = difflib.get_close_matches(str(k), known, n=1)
            named.append(repr(k) + (f" (did you mean {near[0]!r}?)" if near else ""))
        where = f"in {key!r}" if key else "at the top level"
        return (f"unknown key {', '.join(named)} {where}; the known keys are "
                f"{', '.join(known)}")
    value = _short(error.instance)
    message = error.message.replace(repr(error.instance), value)
    if (error.validator == "type" and error.validator_value == "string"
            and isinstance(error.instance, (int, float))):
        message += " (a physical quantity is written with its unit, e.g. '2mm' or '200GPa')"
    return f"key {key or '<top level>'!r} = {value}: {message}"


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= SHOWN_VALUE else text[:SHOWN_VALUE] + " ..."
