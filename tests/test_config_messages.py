"""The schema's objections to a config, worded for a person (scenes.config_file.schema_error):
the key, a short value, and for an unknown key the known ones and the nearest. A misspelt
study name dumped the whole ``studies`` block before naming itself, with no suggestion."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from roughflow.scenes.config_file import SHOWN_VALUE, schema_error

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = yaml.safe_load((ROOT / "workflow" / "schemas" / "config.schema.yaml").read_text())
CONFIG = yaml.safe_load((ROOT / "config" / "test.yaml").read_text())


def _with(change) -> dict:
    config = copy.deepcopy(CONFIG)
    change(config)
    return config


def test_a_valid_config_has_no_objection():
    assert schema_error(CONFIG, SCHEMA) is None


def test_a_misspelt_study_is_named_with_the_nearest_and_no_dump():
    config = _with(lambda c: c["studies"].update(
        threshold_vs_gama=c["studies"].pop("threshold_vs_gamma")))
    message = schema_error(config, SCHEMA)
    assert message.startswith("unknown key 'threshold_vs_gama' (did you mean "
                              "'threshold_vs_gamma'?) in 'studies'; the known keys are ")
    assert "flow_isotropic" in message and "seeds_per_job" not in message  # no dump


@pytest.mark.parametrize(("where", "typo", "meant"), [
    (("studies", "threshold_vs_gamma"), "seed", "seeds"),
    ((), "result", "results"),
])
def test_an_unknown_key_gets_the_nearest_known_one(where, typo, meant):
    def change(c):
        node = c
        for k in where:
            node = node[k]
        node[typo] = node.pop(meant, 1)

    message = schema_error(_with(change), SCHEMA)
    assert f"unknown key {typo!r} (did you mean {meant!r}?)" in message


def test_a_number_where_a_quantity_goes_asks_for_its_unit():
    config = _with(lambda c: c["studies"]["measured"].update(seal_width=2))
    message = schema_error(config, SCHEMA)
    assert message.startswith("key 'studies.measured.seal_width' = 2: ")
    assert "with its unit, e.g. '2mm'" in message


def test_a_long_value_is_shortened():
    config = _with(lambda c: c["studies"]["threshold_vs_gamma"].update(
        gamma={"a": list(range(100))}))
    message = schema_error(config, SCHEMA)
    assert "key 'studies.threshold_vs_gamma.gamma' = {'a': [0, 1, 2" in message
    assert " ...:" in message and len(message) < 3 * SHOWN_VALUE + 200


def test_a_value_given_twice_in_a_sweep_list_is_refused():
    # [1, 3, 3] was planned as [1, 3] without a word, likely a typo for another value
    config = _with(lambda c: c["studies"]["threshold_vs_gamma"].update(gamma=[1, 3, 3]))
    message = schema_error(config, SCHEMA)
    assert message.startswith("key 'studies.threshold_vs_gamma.gamma' = [1, 3, 3]: ")
    assert "non-unique" in message
