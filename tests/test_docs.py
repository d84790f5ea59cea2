"""The documentation exists, matches the code, and its examples work."""

import re
from pathlib import Path

import pytest
import yaml

from e2esim.docs_reference import render
from e2esim.runner.scenario import Scenario
from quick_runs import scenario_names

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
REQUIRED = ["index.md", "user-guide.md", "scenario-reference.md", "output-format.md", "writing-a-module.md",
            "conventions.md", "errata.md", "verification.md", "theory/cross-pol-error.md", "theory/ionosphere.md",
            "theory/calibration.md", "theory/retrieval.md", "theory/ground-cancellation.md", "architecture.md"]


def test_scenario_reference_is_current():
    committed = (DOCS / "scenario-reference.md").read_text()
    assert committed == render(), "docs/scenario-reference.md is stale: run `make reference`"


@pytest.mark.parametrize("name", REQUIRED)
def test_required_docs_exist_and_their_links_resolve(name):
    path = DOCS / name
    text = path.read_text()
    assert len(text) > 1000
    for target in re.findall(r"\]\(([^)#:]+)\)", text):
        assert (path.parent / target).exists(), f"{name} links to missing {target}"


def test_readme_opens_with_the_two_commands_and_ci_runs_the_second():
    lines = [ln for ln in (ROOT / "README.md").read_text().splitlines() if ln.strip()]
    assert lines[0].startswith("# e2esim")
    assert lines[1] == "```sh" and lines[2].startswith("make demo") and lines[3].startswith("make test")
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci == "make test"


def test_yaml_examples_in_the_docs_are_valid_scenarios():
    text = (DOCS / "index.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, re.S)
    assert blocks
    for block in blocks:
        Scenario(yaml.safe_load(block), "docs/index.md").resolve()


def test_readme_links_resolve():
    text = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(([^)#:]+)\)", text)
    assert "docs/user-guide.md" in links and "docs/verification.md" in links
    for target in links:
        assert (ROOT / target).exists(), f"README links to missing {target}"


def test_python_example_of_the_user_guide_runs():
    text = (DOCS / "user-guide.md").read_text()
    block = re.findall(r"```python\n(.*?)```", text, re.S)[-1]
    namespace = {}
    exec(compile(block, "docs/user-guide.md", "exec"), namespace)
    assert float(namespace["moments"].mean) > 0 and namespace["mc"].hv.shape == (10_000, 1)


@pytest.mark.parametrize("scenario", scenario_names())
def test_every_output_scalar_is_documented(scenario, quick_run):
    doc = (DOCS / "output-format.md").read_text()
    names = {name for case in quick_run(scenario)[0].cases for name in case.scalars}
    assert len(names) > 10
    # every `token` of the doc, with <placeholders> standing for any name part
    patterns = [re.compile(re.sub(r"<[^>]+>", r"[A-Za-z0-9_]+", re.escape(t).replace(r"\<", "<").replace(r"\>", ">")))
                for t in re.findall(r"`([^`]+)`", doc)]
    for name in names:
        quantity = name.rpartition(".")[2]
        assert any(p.fullmatch(quantity) for p in patterns), f"{name} is not documented in docs/output-format.md"
