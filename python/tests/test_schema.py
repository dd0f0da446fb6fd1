"""`formica schema`'s JSON Schemas, checked with the reference JSON Schema validator (what editors
do with them): every shipped scenario and sweep file validates, and unknown keys and values out of
range are rejected, by the schema and by the parser alike. (The Rust tests check that the
schemas' keys are exactly the keys the parsers accept; crates/formica-cli/tests/schema.rs.)"""

import json
import pathlib
import subprocess
import tomllib

import jsonschema
import pytest

from conftest import ROOT


def schema(formica_bin, *which):
    out = subprocess.run([formica_bin, "schema", *which], check=True, capture_output=True, text=True)
    s = json.loads(out.stdout)
    jsonschema.Draft7Validator.check_schema(s)
    return jsonschema.Draft7Validator(s)


def errors(validator, text):
    doc = tomllib.loads(text)
    return [f"{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in validator.iter_errors(doc)]


def toml_files(*dirs):
    files = sorted(p for d in dirs for p in (ROOT / d).glob("*.toml"))
    assert files, dirs
    return files


def test_the_scenario_schema_validates_every_shipped_scenario(formica_bin):
    v = schema(formica_bin)
    for path in toml_files("scenarios", "examples/custom-controller/scenarios"):
        assert errors(v, path.read_text()) == [], path


def test_the_sweep_schema_validates_every_shipped_experiment(formica_bin):
    v = schema(formica_bin, "sweep")
    files = toml_files("experiments") + [ROOT / "examples/custom-controller/sweep.toml"]
    for path in files:
        assert errors(v, path.read_text()) == [], path


BASE = (ROOT / "scenarios/seed-transport.toml").read_text()


@pytest.mark.parametrize(
    "what,text",
    [
        ("unknown top-level key", 'colour = "red"\n' + BASE),
        ("unknown key in [run]", BASE.replace("[run]", "[run]\nticks_hz = 10")),
        ("a typo in a robot group", BASE.replace("[[robots]]", '[[robots]]\ncontroler = "occlusion"')),
        ("tick rate out of range", BASE.replace("tick_hz = 10", "tick_hz = 0.5")),
    ],
)
def test_the_scenario_schema_and_the_parser_reject(formica_bin, tmp_path, what, text):
    v = schema(formica_bin)
    assert errors(v, BASE) == []
    assert errors(v, text), f"{what}: accepted by the schema"
    path = tmp_path / "t.toml"
    path.write_text(text)
    out = subprocess.run([formica_bin, "check", str(path)], capture_output=True, text=True)
    assert out.returncode == 2, f"{what}: accepted by the parser"
    assert "t.toml:" in out.stderr


def test_the_sweep_schema_rejects_an_unknown_key(formica_bin):
    v = schema(formica_bin, "sweep")
    base = pathlib.Path(ROOT / "experiments/smoke.toml").read_text()
    assert errors(v, base) == []
    assert errors(v, 'seed = "1..3"\n' + base), "unknown sweep key accepted"
