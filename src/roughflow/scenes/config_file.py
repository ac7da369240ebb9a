"""Checks of a workflow config file that its loaded form can no longer show.

PyYAML (and so Snakemake) keeps the last of two equal keys in one mapping without a word:
a study block given twice, or a ``seeds:`` repeated inside one, would silently drop the
first. :func:`check_config_file` refuses such a file, naming the key and both lines.
"""

from __future__ import annotations

import os
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
