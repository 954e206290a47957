#!/usr/bin/env python3
"""Tests of the `fxshade` Python package, run by scripts/test after the wheel
is built (maturin) and installed into a fresh virtual environment.

    python python/tests/run_tests.py       (fxshade on the PATH)

Expected values come from elsewhere: the vector files `fxshade vectors`
writes (which the simulators check against the RTL), closed forms for the
reference and the conversions, the command line's own messages, and the
emitted RTL simulated by Icarus under cocotb. Ends with a line in cargo's
format, `test result: ok. P passed; F failed; ...`, which scripts/test adds
to its total.
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

import fxshade

REPO = Path(__file__).resolve().parents[2]
FXSHADE = shutil.which("fxshade")
TESTS = []


def test(f):
    TESTS.append(f)
    return f


def run(*args, check=True):
    p = subprocess.run([FXSHADE, *args], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"fxshade {' '.join(args)}: {p.stderr}")
    return p


def read_vectors(d):
    """(inputs, expected) code arrays of a vector directory, from its hex
    files and manifest (the ovf field first among the expected ones)."""
    m = json.loads((d / "manifest.json").read_text())

    def fields(lines, spec):
        rows = []
        for line in lines:
            v = int(line, 16)
            row = []
            for f in spec["fields"]:
                c = (v >> f["lsb"]) & ((1 << f["width"]) - 1)
                if f["signed"] and c >> (f["width"] - 1):
                    c -= 1 << f["width"]
                row.append(c)
            rows.append(row)
        return np.array(rows, dtype=np.int64)

    ins = fields((d / "inputs.hex").read_text().split(), m["inputs"])
    exp = fields((d / "expected.hex").read_text().split(), m["expected"])
    has_ovf = m["expected"]["fields"][0]["name"] == "ovf"
    return m, ins, exp, has_ovf


@test
def eval_gives_the_vector_files_values_for_every_unit_and_variant():
    units = json.loads(run("rtl", "list", "--json").stdout)
    assert sorted(u["unit"] for u in units) == sorted(fxshade.units())
    with tempfile.TemporaryDirectory() as tmp:
        for u in units:
            for v in u["variants"]:
                sets = [s.strip() for s in v["set"].split(";") if s.strip()]
                d = Path(tmp) / f"{u['unit']}-{v['name']}"
                args = ["vectors", u["unit"], "--count", "400", "--seed", "1", "--out", str(d)]
                for s in sets:
                    args += ["--set", s]
                run(*args)
                m, ins, exp, has_ovf = read_vectors(d)
                unit = fxshade.Unit(u["unit"], set=sets)
                out, flags = unit.eval(ins)
                want = exp[:, 1:] if has_ovf else exp
                assert np.array_equal(out, want), f"{u['unit']} {v['name']}"
                if has_ovf:
                    assert np.array_equal(flags.astype(np.int64), exp[:, 0]), u["unit"]
                    assert unit.flags == m["ovf_bits_msb_first"]
                assert [p["name"] for p in unit.inputs] == [f["name"] for f in m["inputs"]["fields"]]


@test
def manifests_follow_the_schema():
    import jsonschema

    schema = json.loads((REPO / "schema/manifest.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    v = jsonschema.Draft202012Validator(schema)
    manifests = [(str(p), json.loads(p.read_text())) for p in sorted(REPO.glob("testvectors/*/manifest.json"))]
    assert len(manifests) == 7, manifests
    for name in fxshade.units():
        m = json.loads(fxshade.Unit(name).manifest_json())
        manifests.append((f"Unit({name!r}).manifest_json()", m))
        assert m["layout"] == fxshade.Unit(name).layout
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "s"
        run("vectors", "pipeline", "--count", "300", "--shard", "1/2", "--no-hex", "--out", str(d))
        manifests.append(("a shard without hex files", json.loads((d / "manifest.json").read_text())))
    for what, m in manifests:
        errors = [e.message for e in v.iter_errors(m)]
        assert not errors, (what, errors)
        assert m["manifest_version"] == 1, what
    # The schema has teeth: an unknown field, a bad format are refused.
    m = dict(manifests[0][1], extra=1)
    assert list(v.iter_errors(m)), "an unknown key passed"
    m = json.loads(json.dumps(manifests[0][1]))
    m["inputs"]["fields"][0]["format"] = "X2F14"
    assert list(v.iter_errors(m)), "a bad format passed"


@test
def reference_is_the_closed_form_of_the_quadratic_normalizer():
    unit = fxshade.Unit("normalize")
    m = json.loads(unit.manifest_json())
    c2, c1, c0 = m["parameters"]["coefficients"]["values"]  # highest power first: a, b, c
    rng = np.random.default_rng(5)
    v = rng.uniform(-1.2, 1.2, size=(1000, 3))
    d = (v * v).sum(axis=1, keepdims=True)
    want = v * (c0 + c1 * d + c2 * d * d)
    got = unit.reference(v)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-15), np.abs(got - want).max()
    # The bit-exact model stays near it on unit-length inputs.
    n = v / np.sqrt(d)
    codes = unit.input_codes(n * 0.9)
    out, _ = unit.eval(codes)
    err = np.abs(unit.output_values(out) - unit.reference(unit.input_values(codes))).max()
    assert err < 2e-3, err


@test
def conversions_round_half_even_and_refuse_what_does_not_fit():
    unit = fxshade.Unit("normalize")  # I2F14 ports
    x = np.array([[0.5, -1.25, 3 / 16384 / 2], [1 / 32768, 5 / 32768, -3 / 32768]])
    # numpy's round is half to even: an independent rounding.
    want = np.round(x * 16384).astype(np.int64)
    assert np.array_equal(unit.input_codes(x), want)
    assert np.array_equal(unit.input_values(want), want / 16384.0)
    try:
        unit.input_codes(np.array([[2.0, 0.0, 0.0]]))
        raise AssertionError("2.0 fits no I2F14 code")
    except ValueError as e:
        assert "input n_x" in str(e) and "outside" in str(e), e


@test
def errors_are_the_command_lines_and_codes_are_never_wrapped():
    try:
        fxshade.Unit("nope")
        raise AssertionError("an unknown unit opened")
    except ValueError as e:
        assert "unknown unit `nope`" in str(e), e
    bad = "normalize.d.format=I99F0"
    cli = run("config", "check", "/dev/null", "--set", bad, check=False)
    assert cli.returncode != 0
    try:
        fxshade.Unit("normalize", set=[bad])
        raise AssertionError("a bad override was accepted")
    except ValueError as e:
        assert str(e) and str(e) in cli.stderr, (str(e), cli.stderr)
    unit = fxshade.Unit("normalize", set={"normalize.method": "linear"})
    assert unit.module == "normalize"
    for codes, what in [
        (np.array([[0, 32768, 0]]), "code 32768 of input n_y lies outside I2F14"),
        (np.array([[0, 0]]), "rows of 3 values"),
    ]:
        try:
            unit.eval(codes)
            raise AssertionError(f"{codes} was evaluated")
        except ValueError as e:
            assert what in str(e), e
    # Any integer array numpy casts to int64 without loss is taken; a float
    # array is not (it would be truncated).
    out32, _ = unit.eval(np.array([[9000, -12000, 3000]], dtype=np.int32))
    out64, _ = unit.eval(np.array([[9000, -12000, 3000]], dtype=np.int64))
    assert np.array_equal(out32, out64)
    try:
        unit.eval(np.array([[0.5, 0.0, 0.0]]))
        raise AssertionError("a float array was evaluated")
    except TypeError as e:
        assert "int64" in str(e), e
    try:
        unit.output_values(np.array([[10**15, 0, 0]]))
        raise AssertionError("a code outside its format was decoded")
    except ValueError as e:
        assert "out_x" in str(e) and "outside" in str(e), e
    try:
        fxshade.Unit("normalize", config="a.toml", toml="")
        raise AssertionError("config and toml together were accepted")
    except ValueError as e:
        assert "not both" in str(e), e
    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
        f.write("[normalize\n")
    try:
        fxshade.Unit("normalize", config=f.name)
        raise AssertionError("a broken file was accepted")
    except ValueError as e:
        assert f"{f.name}:1" in str(e), e
    finally:
        os.unlink(f.name)


def cocotb(unit, out, *extra):
    p = subprocess.run(
        [sys.executable, str(REPO / "python/examples/cocotb/run_cocotb.py"), unit,
         "--out", str(out), *extra],
        capture_output=True,
        text=True,
    )
    last = (p.stdout.strip().splitlines() or [""])[-1]
    return p.returncode, last, p.stdout + p.stderr


@test
def cocotb_scoreboard_passes_on_the_emitted_rtl_and_fails_on_a_mutant():
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        rc, last, log = cocotb("normalize", tmp / "n", "--n", "2000", "--stall", "30")
        assert rc == 0 and last == "2000 passed, 0 failed", log
        # A mutant: the lowest bit of the first coefficient constant flipped.
        v = (tmp / "n/normalize.v").read_text()
        at = v.index("localparam signed")
        end = v.index(";", at)
        h = v.rindex("h", at, end)
        digits = v[h + 1 : end - 1]
        flipped = format(int(digits, 16) ^ 1, f"0{len(digits)}x")
        (tmp / "mutant.v").write_text(v[: h + 1] + flipped + v[end - 1 :])
        rc, last, log = cocotb("normalize", tmp / "m", "--n", "2000", "--rtl", str(tmp / "mutant.v"))
        assert rc != 0, log
        passed, failed = int(last.split()[0]), int(last.split()[2])
        assert failed > 0 and passed + failed == 2000, log


@test
def cocotb_scoreboard_drives_the_smooth_pipeline_top_through_its_set_up_ports():
    with tempfile.TemporaryDirectory() as tmp:
        rc, last, log = cocotb("pipeline", Path(tmp) / "p", "--n", "1500", "--seed", "4")
        assert rc == 0 and last == "1500 passed, 0 failed", log


@test
def the_package_is_the_installed_wheel():
    # scripts/test installs the wheel into a fresh virtual environment.
    assert sys.prefix != sys.base_prefix, "not run inside the test's venv"
    assert Path(fxshade.__file__).resolve().is_relative_to(Path(sys.prefix).resolve()), fxshade.__file__
    assert fxshade.ABI_VERSION == 1


def main():
    if FXSHADE is None:
        sys.exit("run_tests.py: fxshade is not on the PATH (cargo build --release; PATH=target/release:$PATH)")
    passed = failed = 0
    for t in TESTS:
        try:
            t()
            print(f"test python::{t.__name__} ... ok", flush=True)
            passed += 1
        except Exception:
            print(f"test python::{t.__name__} ... FAILED", flush=True)
            traceback.print_exc()
            failed += 1
    status = "ok" if failed == 0 else "FAILED"
    print(f"test result: {status}. {passed} passed; {failed} failed; 0 ignored; 0 measured; 0 filtered out")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
