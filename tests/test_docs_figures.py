"""The figures in docs and the numbers the docs quote from them are not stale.

docs/figures.toml lists every file in docs/img with the command that regenerates it; `make
figures` runs those commands.  Checked here: the manifest, docs/img, the pages that show each
figure and the Makefile agree; every command's script exists and takes the options it is given;
the numbers docs/sweeps.md quotes from the Monte Carlo figures equal the records the figures
were drawn from; and six of the Monte Carlo record's points, rerun on a freshly built FMU, give
the record's outcome (a figure drawn before a change of the model fails here)."""
from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from conftest import ROOT

DOCS = ROOT / "docs"
MANIFEST = tomllib.loads((DOCS / "figures.toml").read_text())["figure"]


def _flat(text: str) -> str:
    """Shell text as one line: continuations joined, runs of blanks as one space."""
    return re.sub(r"\s+", " ", text.replace("\\\n", " "))


def _record(name: str) -> dict:
    return json.loads((DOCS / "img" / name).read_text())


def test_every_file_in_docs_img_is_in_the_manifest_and_back():
    listed = {f["file"] for f in MANIFEST} | {f["record"] for f in MANIFEST if "record" in f}
    present = {f"img/{p.name}" for p in (DOCS / "img").iterdir()}
    assert present - listed == set(), "in docs/img, not in docs/figures.toml"
    assert listed - present == set(), "in docs/figures.toml, not in docs/img"


def test_every_image_a_page_shows_is_listed_with_that_page():
    """Each page that shows a docs/img figure is among the figure's pages; the first page (the
    figure's home) gives its exact command; every other page gives the command or points to
    `make figures` / docs/figures.toml."""
    pages = {f["file"]: f["pages"] for f in MANIFEST}
    commands = {f["file"]: f["command"] for f in MANIFEST}
    for page in [*DOCS.glob("*.md"), ROOT / "README.md"]:
        rel = "../README.md" if page.name == "README.md" else page.name
        for image in re.findall(r"!\[[^\]]*\]\(((?:docs/)?img/[^)]+)\)", page.read_text()):
            image = image.removeprefix("docs/")
            assert image in pages, f"{page.name} shows {image}, which docs/figures.toml does not list"
            assert rel in pages[image], f"{page.name} shows {image}; docs/figures.toml does not name the page"
    for f in MANIFEST:
        home = _flat((DOCS / f["pages"][0]).read_text())
        assert _flat(f["command"]) in home, (f["file"], f["pages"][0])
        for other in f["pages"][1:]:
            text = _flat((DOCS / other).read_text())
            assert _flat(f["command"]) in text or "make figures" in text or "figures.toml" in text, (f["file"], other)


def test_make_figures_runs_every_command_and_each_command_takes_its_options():
    recipe = re.search(r"^figures:.*?\n((?:\t.*\n)+)", (ROOT / "Makefile").read_text(), re.M).group(1)
    lines = [_flat(line.strip().replace("$(PY)", "python")) for line in recipe.splitlines()]
    commands = list(dict.fromkeys(f["command"] for f in MANIFEST))
    assert [line for line in lines if "pip install" not in line] == commands
    options: dict[str, set[str]] = {}
    for command in commands:
        argv = shlex.split(command)
        assert argv[0] == "python" and (ROOT / argv[1]).is_file(), command
        options.setdefault(argv[1], set()).update(a for a in argv[2:] if a.startswith("--"))
    helps = {script: subprocess.Popen([sys.executable, str(ROOT / script), "--help"], stdout=subprocess.PIPE,
                                      stderr=subprocess.PIPE, text=True, cwd=ROOT) for script in options}
    for script, process in helps.items():  # the scripts import gyrowheel: started together, a few s
        out, err = process.communicate(timeout=120)
        assert process.returncode == 0, err[-2000:]
        for option in sorted(options[script]):
            assert re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", out), (script, option)


def test_sweeps_page_quotes_the_monte_carlo_records():
    """docs/sweeps.md's numbers are the records' (the figure's own), rounded as the page prints them."""
    text = _flat((DOCS / "sweeps.md").read_text())
    s = _record("sweep_monte_carlo.json")["summary"]
    quoted = (f"**{100 * s['success']:.1f}% success** (95% Wilson interval {100 * s['lo']:.1f}-{100 * s['hi']:.1f}%, "
              f"{s['n']} runs); the worst lean of a success is {s['worst_lean_deg']:.1f} deg from upright")
    assert quoted in text
    assert f"95th percentile {s['p95_lean_deg']:.1f} deg; median fall time {s['median_fall']:.1f} s" in text
    assert f"{s['failed']} of the 2000 samples ({100 * s['failed'] / 2000:.0f}%)" in text
    loop = _record("sweep_monte_carlo_closed_loop.json")["summary"]
    up, push = loop["lean_deg=0"], loop["lean_deg=-5"]
    assert (f"**Upright start: {100 * up['success']:.0f}% success** ({up['n']} admissible runs, 95% interval "
            f"{100 * up['lo']:.1f}-{100 * up['hi']:.0f}%)") in text
    assert (f"**The mission's 5 deg push: {100 * push['success']:.1f}% success** ({100 * push['lo']:.1f}-"
            f"{100 * push['hi']:.1f}%)") in text
    assert f"the worst lean of a success {push['worst_lean_deg']:.1f} deg" in text


def test_sweeps_page_quotes_the_steady_precession_record():
    c = _record("sweep_paper_figs_5_6.json")
    quoted = ", ".join(f"{c[n]['agree']}/{c[n]['runs']}" for n in ("region_paper", "region_k030_045"))
    fig = f"{c['fig5']['agree']}/{c['fig5']['runs']} (Fig. 5), {c['fig6']['agree']}/{c['fig6']['runs']} (Fig. 6)"
    assert f"agree on {fig}, {quoted.replace(', ', ' and ')} runs" in _flat((DOCS / "sweeps.md").read_text())


@pytest.fixture(scope="module")
def friction_build(example_build):
    return example_build("paper_earth_friction")


def test_monte_carlo_record_is_what_the_model_gives_today(friction_build):
    """Six of the record's points (three that survived, three that fell) rerun in-process: the
    same outcome and fall time.  A model change that moves the outcome (a new friction law, say)
    makes the figure and its quoted numbers stale, and fails here.  Builds the friction scene's
    FMU (about 20 s on 2 cores: no shared build has its effects); the six runs take a second."""
    import gyrowheel
    record = _record("sweep_monte_carlo.json")
    argv = shlex.split(record["command"])
    assert argv[2] == "examples/scenes/paper_earth_friction.toml" and "beta_min_deg=30" in argv
    settings = dict(stop_time=float(argv[argv.index("--stop-time") + 1]),
                    output_interval=float(argv[argv.index("--output-interval") + 1]))
    samples = record["samples"]
    assert [s["survived"] for s in samples] == [True] * 3 + [False] * 3
    table = gyrowheel.sweep(friction_build.fmu, points=[{k: s[k] for k in ("M", "k_diam", "k_axial", "c_rr", "c_pivot")}
                                                       for s in samples],
                            fixed={"beta_min_deg": 30.0}, metrics="survived,fall_time", workers=0, **settings)
    assert (table["status"] == "ok").all(), table["reason"].tolist()
    assert table["survived"].tolist() == [s["survived"] for s in samples]
    for got, s in zip(table["fall_time"], samples):
        if s["fall_time"] is not None:
            assert got == pytest.approx(s["fall_time"], abs=1e-6)
