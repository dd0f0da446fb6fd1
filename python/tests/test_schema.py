"""`formica schema`'s JSON Schemas, checked with the reference JSON Schema validator (what editors
do with them): every shipped scenario and sweep file validates, and unknown keys and values out of
range are rejected, by the schema and by the parser alike. (The Rust tests check that the
schemas' keys are exactly the keys the parsers accept; crates/formica-cli/tests/schema.rs.)"""

import json
import subprocess
import tomllib

import jsonschema
import pytest

from conftest import ROOT


def validator(formica_bin, *which):
    out = subprocess.run([formica_bin, "schema", *which], check=True, capture_output=True, text=True)
    s = json.loads(out.stdout)
    jsonschema.Draft7Validator.check_schema(s)
    return jsonschema.Draft7Validator(s)


@pytest.fixture(scope="module")
def scenario_schema(formica_bin):
    return validator(formica_bin)


@pytest.fixture(scope="module")
def sweep_schema(formica_bin):
    return validator(formica_bin, "sweep")


def errors(v, text):
    doc = tomllib.loads(text)
    return [f"{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in v.iter_errors(doc)]


def toml_files(*dirs):
    files = sorted(p for d in dirs for p in (ROOT / d).glob("*.toml"))
    assert files, dirs
    return files


def test_the_scenario_schema_validates_every_shipped_scenario(scenario_schema):
    for path in toml_files("scenarios", "examples/custom-controller/scenarios"):
        assert errors(scenario_schema, path.read_text()) == [], path


def test_the_sweep_schema_validates_every_shipped_experiment(sweep_schema):
    files = toml_files("experiments") + [ROOT / "examples/custom-controller/sweep.toml"]
    for path in files:
        assert errors(sweep_schema, path.read_text()) == [], path


BASE = (ROOT / "scenarios/seed-transport.toml").read_text()


@pytest.mark.parametrize(
    "what,text",
    [
        ("unknown top-level key", 'colour = "red"\n' + BASE),
        ("unknown key in [run]", BASE.replace("[run]", "[run]\nticks_hz = 10")),
        ("a typo in a robot group", BASE.replace("[[robots]]", '[[robots]]\ncontroler = "occlusion"')),
        ("tick rate out of range", BASE.replace("tick_hz = 10", "tick_hz = 0.5")),
        # The parser wants more than 0; the schema said "0 to 1000000" until it said so too.
        ("a run of no time", BASE.replace("duration_s = 1200", "duration_s = 0")),
    ],
)
def test_the_scenario_schema_and_the_parser_reject(formica_bin, scenario_schema, tmp_path, what, text):
    assert errors(scenario_schema, BASE) == []
    assert errors(scenario_schema, text), f"{what}: accepted by the schema"
    path = tmp_path / "t.toml"
    path.write_text(text)
    out = subprocess.run([formica_bin, "check", str(path)], capture_output=True, text=True)
    assert out.returncode == 2, f"{what}: accepted by the parser"
    assert "t.toml:" in out.stderr


def test_the_sweep_schema_rejects_an_unknown_key(sweep_schema):
    base = (ROOT / "experiments/smoke.toml").read_text()
    assert errors(sweep_schema, base) == []
    assert errors(sweep_schema, 'seed = "1..3"\n' + base), "unknown sweep key accepted"
