"""The free-choice rule (CONTRIBUTING.md, *Free choices*): a claim that rests on a value the
paper leaves open is decided under every value of it, and the registry refuses one that is not."""
import json
import re
from pathlib import Path

import pytest

from pfrepro.choices import (FIXED, READING, SWEEP, FreeChoice, FreeChoiceError, check_claim,
                             choices_table, over)
from pfrepro.claims import ClaimsRegistry, check_saved_claims, verdict

BOOK = Path(__file__).resolve().parents[1] / "book"
CHOICES = [FreeChoice("d", "1", READING, "paper gives no value; 1e-6 … 3 run"),
           FreeChoice("T", "100", FIXED, "printed in Sec. 4"),
           FreeChoice("eta", "0.5", SWEEP, "swept 0.1 … 0.9 in Fig. X")]


def test_over_tags_reading_names():
    assert over("d", {0.1: True, "1": False}) == {"d=0.1": True, "d=1": False}


def test_dependency_on_a_reading_needs_tagged_readings():
    reg = ClaimsRegistry("p", choices=CHOICES)
    with pytest.raises(FreeChoiceError, match="'d'"):
        reg.add("a", "A beats B", diff=1.0, diff_se=0.1, depends_on=["d"])
    with pytest.raises(FreeChoiceError, match="'eta'"):
        reg.add("b", "A beats B", readings=over("d", {1: True, 3: True}), depends_on=["d", "eta"])
    c = reg.add("c", "A beats B", diff=1.0, diff_se=0.1, depends_on=["d", "T"],
                readings=over("d", {1: True, 0.1: False}))
    assert c.verdict == "inconclusive"  # the readings decide, not the main diff alone
    # a "reading" run only at the main value covers nothing
    with pytest.raises(FreeChoiceError, match="only at its main value"):
        reg.add("e", "A beats B", readings={**over("d", {1: True}), **over("eta", {0.5: True})},
                depends_on=("d", "eta"))
    assert reg.add("e", "A beats B", readings={**over("d", {1: True, 3: True}), **over("eta", {0.1: True})},
                   depends_on=("d", "eta")).verdict == "reproduced"


def test_fixed_choice_needs_no_reading_and_unknown_name_is_an_error():
    reg = ClaimsRegistry("p", choices=CHOICES)
    assert reg.add("a", "x", qualitative=True, depends_on="T").verdict == "reproduced"
    with pytest.raises(FreeChoiceError, match="not a row"):
        reg.add("b", "x", qualitative=True, depends_on=["typo"])
    with pytest.raises(FreeChoiceError):
        ClaimsRegistry("p").add("c", "x", qualitative=True, depends_on=["d"])


def test_combined_tags_cover_each_choice():
    check_claim("x", ["d", "eta"], {"d=1, eta=0.2": True, "d=3, eta=0.5": True}, None, CHOICES)
    with pytest.raises(FreeChoiceError, match="'d' but is decided only at its main value"):
        check_claim("x", ["d", "eta"], {"d=1, eta=0.2": True}, None, CHOICES)


def test_published_number_under_readings():
    # matched under the main reading only -> inconclusive; under all -> reproduced; none -> not
    assert verdict(published=5.0, reproduced=5.1, se=0.1, reading_values={"s=1": (8.0, 0.2)}) == "inconclusive"
    assert verdict(published=5.0, reproduced=5.1, se=0.1, reading_values={"s=1": (5.2, 0.2)}) == "reproduced"
    assert verdict(published=5.0, reproduced=8.1, se=0.1, reading_values={"s=1": (8.0, 0.2)}) == "not reproduced"
    assert verdict(published=5.0, reproduced=8.1, se=0.1, reading_values={"s=1": (8.0, 0.2)},
                   readings={"s=1": True, "s=0": True}) == "qualitatively reproduced"
    with pytest.raises(ValueError):
        verdict(published=5.0, reading_values={"s=1": (8.0, 0.2)})


def test_not_checkable_overrides_numbers():
    reg = ClaimsRegistry("p", choices=CHOICES)
    c = reg.add("a", "IMMPF mean 119 m", published=119.0, reproduced=119.0, se=1.0,
                not_checkable="our noise values set the level")
    assert c.verdict == "not checkable" and "noise values" in c.test_text()


def test_free_choice_rows_are_validated():
    with pytest.raises(ValueError):
        FreeChoice("d", "1", "maybe", "x")
    with pytest.raises(ValueError):
        FreeChoice("a b", "1", FIXED, "x")
    with pytest.raises(ValueError):
        FreeChoice("d", "1", FIXED, "  ")
    with pytest.raises(ValueError):
        ClaimsRegistry("p", choices=CHOICES + [CHOICES[0]])
    assert list(choices_table(CHOICES).columns) == ["choice", "value", "status", "reason"]


def test_saved_claims_are_rechecked(tmp_path):
    reg = ClaimsRegistry("p", choices=CHOICES)
    reg.add("a", "x", readings=over("d", {1: True, 3: True}), depends_on=["d"])
    reg.save(tmp_path)
    assert check_saved_claims(tmp_path) == 1
    # a saved claim whose readings lost their tag (edited by hand) fails the re-check
    path = tmp_path / "p.json"
    rows = json.loads(path.read_text())
    rows[0]["readings"] = {"one": True}
    path.write_text(json.dumps(rows))
    with pytest.raises(FreeChoiceError):
        check_saved_claims(tmp_path)


PAPER_CHAPTERS = ["20_gpff.md", "30_ekf_pf.md", "40_cmspf.md", "50_dpf.md", "60_immpf.md", "70_synthesis.md"]
#: Chapters not yet converted to the rule (each conversion removes its chapter; must end empty).
NOT_YET = set()


@pytest.mark.parametrize("chapter", PAPER_CHAPTERS)
def test_every_claims_registry_is_given_its_chapter_choices(chapter):
    """Each paper chapter builds its registry with the assumptions table's choices, so that
    the registry can refuse a claim whose free choice is not run under every reading."""
    if chapter in NOT_YET:
        pytest.xfail("chapter not yet converted to the free-choice rule")
    src = (BOOK / chapter).read_text(encoding="utf-8")
    moved = re.search(r'get_paper\("(\w+)"\)\.run\(', src)
    if moved:   # the registry is Paper.run's, made with the experiment module's CHOICES
        from pfrepro.papers import get_paper

        import inspect

        paper = get_paper(moved.group(1))
        assert "ClaimsRegistry(" not in src, f"{chapter}: a second registry beside Paper.run's"
        assert paper.experiments_module.CHOICES
        assert "ClaimsRegistry(self.key, choices=E.CHOICES)" in inspect.getsource(type(paper).run)
        return
    calls = re.findall(r"ClaimsRegistry\(([^)]*)\)", src)
    assert calls, f"{chapter} records no claims"
    assert all("choices=" in c for c in calls), f"{chapter}: ClaimsRegistry(...) without choices="


def test_claims_of_the_last_build_respect_the_rule():
    """The claims the last book build saved (if any) pass the same check."""
    d = BOOK / "_claims"
    if not any(d.glob("*.json")):
        pytest.skip("no book build in this checkout")
    assert check_saved_claims(d) > 0


def test_readings_of_an_undeclared_choice_are_refused():
    # the claim's own readings show that it rests on 'd': it must say so
    with pytest.raises(FreeChoiceError, match="does not declare"):
        check_claim("x", [], {"d=1": True, "d=3": False}, None, CHOICES)
    with pytest.raises(FreeChoiceError, match="does not declare"):
        check_claim("x", ["eta"], {"eta=0.1": True}, {"d=3": (1.0, 0.1)}, CHOICES)


PLACE = re.compile(r"\bl\.\s*\d|\blines?\s+\d|\bsec(tion)?s?\.?\s*\d|\btables?\s*\d|\bfig(ure)?s?\.?\s*\d|\beqs?\.?\s*\(?\d"
                   r"|\bsteps?\s*\d|\babstract\b|\bconclusion\b", re.I)


@pytest.mark.parametrize("paper", ["ekf_pf_li2012", "gpff_zhang2016", "cmspf_ning2011", "dpf_hou2008",
                                   "immpfor_zhou2017", "synthesis"])
def test_fixed_by_the_paper_cites_the_paper(paper):
    """A row 'fixed by the paper' says where the paper fixes it; a value we chose is a design choice."""
    import importlib

    E = importlib.import_module(f"pfrepro.experiments.{paper}")
    bad = [f"{c.name}: {c.source!r}" for c in E.CHOICES if c.status == FIXED and not PLACE.search(c.source)]
    assert not bad, f"{paper}: rows fixed by the paper without the paper's place: {bad}"


def test_orderings_state_their_size_and_runs():
    from pfrepro.claims import plan_problems

    reg = ClaimsRegistry("p")
    reg.add("a", "A beats B", diff=1.0, diff_se=0.1)
    reg.add("b", "A beats C", diff=1.0, diff_se=0.1, margin=0.5, runs=20)
    reg.add("c", "A beats D", diff=1.0, diff_se=0.1, effect=0.5, reading_diffs={"x=1": (1, 0.1, 20), "x=2": (1, 0.1)})
    reg.add("d", "cheaper", qualitative=True, basis="count")
    assert plan_problems(reg) == ["p:a: an ordering without a printed effect or a stated margin",
                                  "p:a: a difference without the runs behind it",
                                  "p:c: a difference without the runs behind it"]
