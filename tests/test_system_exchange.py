"""The exchange of gyrowheel's master and of the sweep's: independent of the file's order of the
connections, outputs with direct feedthrough carried in dependency order (also in Initialization
Mode), algebraic loops refused with the loop named, SSP 1.0 connection transformations applied
(ssc:LinearTransformation) or refused by name, units never silently mismatched.

The toy FMU `link` (one build, a few seconds, shared by the module): a state x with x' = -k x,
x(0) = 1, so x(t) = exp(-k t) (no feedthrough), and a pass-through y = u (direct feedthrough,
ModelStructure dependencies), u's start value 5. Every right value below is that closed form.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xmlschema

from gyrowheel.cosim.master import run
from gyrowheel.cosim.exchange import feedthrough
from gyrowheel.cosim.system import Component, Connection, SystemDescription, SystemFileError
from gyrowheel.cosim.ssp import read_ssp, write_ssp
from gyrowheel.fmu_build.builder import build_spec_fmu
from gyrowheel.model.system import System

SCHEMAS = Path(__file__).resolve().parent.parent / "cosim" / "schemas" / "ssp1"
K, U0, STEP = 2.0, 5.0, 0.1


@pytest.fixture(scope="module")
def link_fmu(tmp_path_factory) -> Path:
    s = System("link", "a decaying state and a pass-through")
    k = s.parameter("k", K, "1/s", "decay rate", minimum=0.0)
    u = s.input("u", U0, "1", "passed through")
    x = s.state("x", 1.0, "1", "exp(-k t)")
    s.der(x, -k * x)
    s.output("y", u, "1", "= u")
    return build_spec_fmu(s.spec(), tmp_path_factory.mktemp("link") / "link.fmu").fmu


def chain(fmu: Path, order: str, **linear) -> SystemDescription:
    """src.x -> A.u -> (A.y = A.u) -> B.u: listed in data-flow order ("flow") or reversed."""
    first = Connection("src", "x", "A", "u", **linear)
    second = Connection("A", "y", "B", "u")
    return SystemDescription("chain", [Component(n, fmu) for n in ("src", "A", "B")],
                             [first, second] if order == "flow" else [second, first], 0.0, 1.0)


def test_feedthrough_is_read_from_the_model_structure(link_fmu, tmp_path):
    """FMI 2.0.4 section 2.2.8: an output's dependencies list the knowns it depends on directly
    (of which only inputs matter to a master); no attribute: every known; an empty one: none."""
    assert feedthrough(link_fmu) == {"y": ("u",)}  # x is a state: no input dependency
    variables = "".join(f'<ScalarVariable name="{n}" valueReference="{i}" causality="{c}"><Real/></ScalarVariable>'
                        for i, (n, c) in enumerate([("u", "input"), ("v", "input"), ("s", "local"), ("a", "output"),
                                                    ("b", "output"), ("c", "output")]))
    (tmp_path / "modelDescription.xml").write_text(
        f'<fmiModelDescription fmiVersion="2.0"><ModelVariables>{variables}</ModelVariables><ModelStructure>'
        '<Outputs><Unknown index="4"/><Unknown index="5" dependencies=""/><Unknown index="6" dependencies="3 2"/>'
        '</Outputs></ModelStructure></fmiModelDescription>')
    assert feedthrough(tmp_path) == {"a": ("u", "v"), "c": ("v",)}
    (tmp_path / "modelDescription.xml").write_text((tmp_path / "modelDescription.xml").read_text().replace(
        'dependencies="3 2"', 'dependencies="0"'))
    with pytest.raises(SystemFileError, match="ModelStructure/Outputs has an Unknown with a bad index"):
        feedthrough(tmp_path)


@pytest.mark.parametrize("order", ["flow", "reversed"])
def test_a_chain_of_pass_throughs_does_not_depend_on_the_file_order(link_fmu, order):
    """B.u = A.y = A.u = src.x = exp(-k t) at every communication point, t = 0 included, with the
    connections listed either way. Listed against the flow, copying connection by connection in
    file order would give B A's stale start value at t = 0 (B.y = 5) and a step's delay after."""
    r = run(chain(link_fmu, order), STEP, stop_time=1.0).data
    exact = np.exp(-K * r["time"])
    assert r["B.y"][0] == 1.0 and r["A.y"][0] == 1.0
    np.testing.assert_allclose(r["A.y"], exact, rtol=1e-7)
    np.testing.assert_allclose(r["B.y"], exact, rtol=1e-7)
    np.testing.assert_array_equal(r["B.y"], r["src.x"])  # passed on, not a step late


@pytest.mark.parametrize("connections, loop", [
    ([("A", "y", "B", "u"), ("B", "y", "A", "u")],
     "A.y -> B.u, B.y -> A.u (B.y depends directly on B.u, A.y on A.u"),
    ([("A", "y", "A", "u")], "A.y -> A.u (A.y depends directly on A.u"),
])
def test_an_algebraic_loop_is_refused_with_its_name(link_fmu, tmp_path, connections, loop):
    system = SystemDescription("loop", [Component(n, link_fmu) for n in ("A", "B")],
                               [Connection(*c) for c in connections])
    with pytest.raises(SystemFileError, match="algebraic loop " + re.escape(loop)):
        run(system, STEP, stop_time=1.0)
    with pytest.raises(SystemFileError, match="algebraic loop " + re.escape(loop)):
        write_ssp(system, tmp_path / "loop.ssp")


def test_a_linear_transformation_is_applied_by_the_master_and_the_sweep(link_fmu, tmp_path):
    """src.x -> A.u with factor 3, offset 0.5: A.y = 3 exp(-k t) + 0.5 and B.y the same, read back
    from a schema-valid .ssp by the master and by the sweep (not the untransformed 3 exp(-k t))."""
    from gyrowheel.studies import sweep

    path = write_ssp(chain(link_fmu, "reversed", factor=3.0, offset=0.5), tmp_path / "linear.ssp")
    with zipfile.ZipFile(path) as zf:
        zf.extract("SystemStructure.ssd", tmp_path)
        assert '<ssc:LinearTransformation factor="3.0" offset="0.5"' in zf.read("SystemStructure.ssd").decode()
    xmlschema.XMLSchema10(SCHEMAS / "SystemStructureDescription.xsd").validate(tmp_path / "SystemStructure.ssd")
    r = run(read_ssp(path, tmp_path / "u"), STEP).data
    exact = 3.0 * np.exp(-K * r["time"]) + 0.5
    np.testing.assert_allclose(r["B.y"], exact, rtol=1e-7)
    assert r["B.y"][0] == 3.5
    table = sweep(path, grid={"src.k": [K, 1.0]}, metrics=["final:B.y"], stop_time=1.0,
                  output_interval=STEP, workers=0)
    assert (table["status"] == "ok").all(), table
    for _, row in table.iterrows():
        assert row["final_B.y"] == pytest.approx(3.0 * math.exp(-row["src.k"] * 1.0) + 0.5, rel=1e-7)


MAPPINGS = {
    "BooleanMappingTransformation": '<ssc:MapEntry source="true" target="false"/>',
    "IntegerMappingTransformation": '<ssc:MapEntry source="1" target="2"/>',
    "EnumerationMappingTransformation": '<ssc:MapEntry source="a" target="b"/>',
}


def _edit(path: Path, out: Path, edit) -> Path:
    with zipfile.ZipFile(path) as zf, zipfile.ZipFile(out, "w") as new:
        for name in zf.namelist():
            data = zf.read(name)
            new.writestr(name, edit(data.decode()) if name == "SystemStructure.ssd" else data)
    return out


@pytest.fixture(scope="module")
def plain_chain(link_fmu, tmp_path_factory) -> Path:
    return write_ssp(chain(link_fmu, "flow"), tmp_path_factory.mktemp("chain") / "chain.ssp")


@pytest.mark.parametrize("kind", sorted(MAPPINGS))
def test_each_mapping_transformation_is_refused_in_one_line(plain_chain, tmp_path, kind):
    """Valid SSP 1.0, not applied by the master: refused by name (the CLI: one line, exit 2), not
    run with the value untransformed."""
    mapping = f"<ssc:{kind}>{MAPPINGS[kind]}</ssc:{kind}>"
    path = _edit(plain_chain, tmp_path / f"{kind}.ssp", lambda s: re.sub(
        r'(<ssd:Connection startElement="src"[^>]*?)\s*/>', rf"\1>{mapping}</ssd:Connection>", s, count=1))
    with zipfile.ZipFile(path) as zf:
        zf.extract("SystemStructure.ssd", tmp_path)
    xmlschema.XMLSchema10(SCHEMAS / "SystemStructureDescription.xsd").validate(tmp_path / "SystemStructure.ssd")
    message = (f"connection src.x -> A.u: ssc:{kind} is not supported by gyrowheel's master "
               f"(of the SSP 1.0 transformations only ssc:LinearTransformation is)")
    with pytest.raises(SystemFileError, match=re.escape(message)):
        read_ssp(path, tmp_path / "u")
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "system", "run", str(path)], capture_output=True,
                       text=True, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and message in r.stderr, r.stderr


def test_connector_units_that_differ_are_refused_unless_conversion_is_suppressed(plain_chain, tmp_path):
    """SSP 1.0 converts between the connectors' units unless suppressUnitConversion="true"; the
    master does not convert, so it refuses rather than pass 1 m on as 1 mm."""
    def units(s: str) -> str:  # src.x in m, A.u in mm
        for comp, conn, unit in (("src", "x", "m"), ("A", "u", "mm")):
            head, tail = s.split(f'<ssd:Component name="{comp}"', 1)
            s = head + f'<ssd:Component name="{comp}"' + re.sub(
                rf'(<ssd:Connector name="{conn}"[^>]*>\s*<ssc:Real)[^/]*/>', rf'\1 unit="{unit}"/>', tail, count=1)
        return s
    path = _edit(plain_chain, tmp_path / "units.ssp", units)
    with pytest.raises(SystemFileError, match=re.escape("connection src.x -> A.u: from 'm' to 'mm': unit conversion "
                                                        "is not supported")):
        read_ssp(path, tmp_path / "u")
    suppressed = _edit(path, tmp_path / "suppressed.ssp", lambda s: s.replace(
        '<ssd:Connection startElement="src"', '<ssd:Connection suppressUnitConversion="true" startElement="src"'))
    assert read_ssp(suppressed, tmp_path / "s").connections[0].suppress_unit_conversion


# A connection's children that SSP 1.0 refuses (SystemStructureDescription.xsd: a connection holds at
# most one of ssc:GTransformationChoice, then ConnectionGeometry and Annotations; no attribute factor)
NOT_SSP = {
    "unknown_element": ('<ssc:FooTransformation factor="3"/>', "",
                        "connection src.x -> A.u: ssc:FooTransformation is not an element gyrowheel's reader "
                        "knows here (known: ssc:LinearTransformation, "),
    "two_transformations": ('<ssc:LinearTransformation factor="3"/><ssc:LinearTransformation factor="7"/>', "",
                            "connection src.x -> A.u: 2 transformations (ssc:LinearTransformation, "
                            "ssc:LinearTransformation): SSP 1.0 allows at most one per connection"),
    "unknown_attribute": ("", ' factor="3"',
                          "not valid SSP 1.0 (SystemStructureDescription.xsd): "
                          "Element 'ssd:Connection', attribute 'factor': The attribute 'factor' is not allowed."),
}


@pytest.mark.parametrize("case", sorted(NOT_SSP))
def test_a_connection_the_standard_does_not_allow_is_refused_in_one_line(plain_chain, tmp_path, case):
    """Invalid against the vendored SSP 1.0 schema (checked here with xmlschema, a validator the
    reader does not use): refused by read_ssp, `gyrowheel system run` (one line, exit 2) and a
    sweep, not run untransformed (the unknown element, the attribute: A.y = exp(-k t)) or with one
    of the two transformations silently chosen (the last: A.y = 7 exp(-k t))."""
    from gyrowheel import SweepSpecError
    from gyrowheel.studies import sweep

    inner, attribute, message = NOT_SSP[case]
    path = _edit(plain_chain, tmp_path / f"{case}.ssp", lambda s: re.sub(
        r'(<ssd:Connection startElement="src"[^>]*?)\s*/>', rf"\1{attribute}>{inner}</ssd:Connection>", s, count=1))
    with zipfile.ZipFile(path) as zf:
        zf.extract("SystemStructure.ssd", tmp_path)
    assert not xmlschema.XMLSchema10(SCHEMAS / "SystemStructureDescription.xsd").is_valid(
        tmp_path / "SystemStructure.ssd")
    with pytest.raises(SystemFileError, match=re.escape(message)):
        read_ssp(path, tmp_path / "u")
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "system", "run", str(path)], capture_output=True,
                       text=True, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and message in r.stderr, r.stderr
    with pytest.raises(SweepSpecError, match=re.escape(message)):
        sweep(path, grid={"src.k": [K]}, metrics=["final:A.y"], stop_time=1.0, output_interval=STEP, workers=0)


def test_an_element_the_reader_does_not_know_is_refused_where_it_is(plain_chain, tmp_path):
    """Schema-valid places the reader reads (a component, a connector, a binding's values, which
    SSP 1.0 leaves open to any element) never hide an element it would skip: each is named."""
    cases = {
        "component": (lambda s: s.replace("</ssd:Connectors>", "</ssd:Connectors><ssd:Foo/>", 1),
                      "component 'src': ssd:Foo is not an element gyrowheel's reader knows here"),
        "connector": (lambda s: s.replace('kind="output">', 'kind="output"><ssd:Bar/>', 1),
                      "component 'src', connector 'x': ssd:Bar is not an element gyrowheel's reader knows here"),
        "values": (lambda s: s.replace("</ssd:Connectors>", "</ssd:Connectors><ssd:ParameterBindings>"
                                       "<ssd:ParameterBinding><ssd:ParameterValues><Baz k='1'/></ssd:ParameterValues>"
                                       "</ssd:ParameterBinding></ssd:ParameterBindings>", 1),
                   "component 'src', parameter binding: ssd:ParameterValues: Baz is not an element gyrowheel's "
                   "reader knows here (known: ssv:ParameterSet)"),
    }
    for case, (edit, message) in cases.items():
        path = _edit(plain_chain, tmp_path / f"{case}.ssp", edit)
        with pytest.raises(SystemFileError, match=re.escape(message)):
            read_ssp(path, tmp_path / case)
