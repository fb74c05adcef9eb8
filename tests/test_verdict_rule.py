"""The verdict rule v3 (CONTRIBUTING.md, *The verdict rule*): the truth table in CONTRIBUTING is
parsed and every row is checked against :func:`pfrepro.claims.judge_ordering`, on hand-picked and
on generated inputs, so the documented rule and the code cannot drift apart; then the combination
of readings, excluded readings, published numbers and the runs a plan needs."""
import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfrepro.claims import (CAUSE_COUNT, CAUSE_READING, CAUSE_RUNS, CAUSE_TIE, Z_CRIT, ClaimsRegistry,
                            Judgement, combine_readings, judge, judge_ordering)
from pfrepro.stats import plan_runs

CONTRIBUTING = Path(__file__).resolve().parents[1] / "CONTRIBUTING.md"


def truth_table():
    text = CONTRIBUTING.read_text(encoding="utf-8")
    block = re.search(r"<!-- verdict-truth-table.*?-->\n(.*?)<!-- end verdict-truth-table -->", text, re.S)
    assert block, "CONTRIBUTING.md lost its verdict truth table"
    rows = []
    for line in block.group(1).strip().splitlines()[2:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        rows.append(dict(zip(("effect", "direction", "size", "verdict", "cause"), cells)))
    return rows


TABLE = truth_table()


def conditions(diff, se, effect=None, margin=None, rel_tol=0.10):
    """The row key of the table, computed from the definitions in CONTRIBUTING (not from the code)."""
    lo, hi = diff - Z_CRIT * se, diff + Z_CRIT * se
    direction = "shown" if lo > 0 else "reversed" if hi < 0 else "not shown"
    if effect is not None:
        attained = abs(diff - effect) <= Z_CRIT * se or abs(diff - effect) <= rel_tol * effect
        return "yes", direction, "attained" if attained else "excluded"
    if direction == "not shown" and margin is not None and -margin < lo and hi < margin:
        return "no, margin stated", "not shown, inside the margin", ""
    return "no", direction, ""


def row_for(key):
    eff, direction, size = key
    for row in TABLE:
        if row["effect"] == eff and row["direction"] == direction and (row["size"] == size or not row["size"]):
            return row
    raise AssertionError(f"the truth table has no row for {key}")


def test_the_table_has_every_case_once():
    keys = [(r["effect"], r["direction"], r["size"]) for r in TABLE]
    assert len(keys) == len(set(keys)) == 9
    assert {r["verdict"] for r in TABLE} == {"reproduced", "qualitatively reproduced", "not reproduced",
                                              "inconclusive"}


# one hand-picked example per row of the table: (diff, se, effect, margin)
EXAMPLES = [(1.0, 0.1, 1.05, None), (1.0, 0.1, 2.0, None), (-1.0, 0.1, 1.0, None), (0.01, 0.1, 1.0, None),
            (0.3, 0.3, 0.5, None), (1.0, 0.1, None, None), (-1.0, 0.1, None, None), (0.01, 0.01, None, 0.1),
            (0.1, 0.1, None, None)]


@pytest.mark.parametrize("diff, se, effect, margin", EXAMPLES)
def test_each_row_of_the_table(diff, se, effect, margin):
    row = row_for(conditions(diff, se, effect, margin))
    j = judge_ordering(diff, se, effect=effect, margin=margin)
    assert (j.verdict, j.cause) == (row["verdict"], row["cause"])


def test_every_row_is_reached_by_an_example():
    reached = {tuple(row_for(conditions(*e)).values()) for e in EXAMPLES}
    assert reached == {tuple(r.values()) for r in TABLE}


@settings(max_examples=400, deadline=None)
@given(diff=st.floats(-5, 5), se=st.floats(1e-3, 2), effect=st.one_of(st.none(), st.floats(0.01, 5)),
       margin=st.one_of(st.none(), st.floats(0.01, 5)))
def test_generated_inputs_follow_the_table(diff, se, effect, margin):
    row = row_for(conditions(diff, se, effect, margin if effect is None else None))
    j = judge_ordering(diff, se, effect=effect, margin=margin if effect is None else None)
    assert (j.verdict, j.cause) == (row["verdict"], row["cause"])


def test_the_five_printed_effects_of_the_audit_are_not_reproduced_when_excluded():
    # a margin printed as +0.83 against ours 0 ± 0.01: the size is excluded, the direction not shown
    assert judge_ordering(0.0, 0.01, effect=0.83).verdict == "not reproduced"
    # a printed −26 % mean error (effect 0.26 of a relative diff) against ours −3 % ± 2 %: reversed
    assert judge_ordering(-0.03, 0.02, effect=0.26).verdict == "not reproduced"
    # a direction shown with a smaller size than printed: qualitatively reproduced
    assert judge_ordering(0.10, 0.02, effect=0.26).verdict == "qualitatively reproduced"


def test_runs_needed_is_the_power_plan():
    j = judge_ordering(0.1, 0.2, effect=0.3, runs=20)
    assert j.cause == CAUSE_RUNS and j.runs_needed == plan_runs(0.2 * math.sqrt(20), 0.3) > 20
    assert judge_ordering(0.1, 0.1, runs=20).runs_needed is None  # no size stated: no plan
    assert judge_ordering(0.1, 0.1, margin=0.2, runs=20).runs_needed == plan_runs(0.1 * math.sqrt(20), 0.2)
    assert judge_ordering(0.1, 0.1, margin=0.5, runs=20).cause == CAUSE_TIE  # [-0.1, 0.3] inside ±0.5
    # the plan is large enough: at the planned runs the interval half-width is below the effect
    n = plan_runs(1.0, 0.3)
    assert Z_CRIT * 1.0 / math.sqrt(n) < 0.3
    with pytest.raises(ValueError):
        plan_runs(1.0, 0.0)
    # the plan already met and still undecided (an observed difference below the margin): the runs
    # that would show the observed difference, always more than the runs it had
    j = judge_ordering(0.05, 0.03, margin=0.1, runs=250)
    assert j.cause == CAUSE_RUNS and plan_runs(0.03 * math.sqrt(250), 0.1) <= 250
    assert j.runs_needed == plan_runs(0.03 * math.sqrt(250), 0.05) > 250


def _j(v, c=""):
    return Judgement(v, c)


def test_combine_readings():
    R, Q, N = "reproduced", "qualitatively reproduced", "not reproduced"
    assert combine_readings({"a": _j(R), "b": _j(R)}).verdict == R
    assert combine_readings({"a": _j(R), "b": _j(Q)}).verdict == Q
    assert combine_readings({"a": _j(N), "b": _j(N)}).verdict == N
    j = combine_readings({"a": _j(R), "b": _j(N), "c": _j("inconclusive", CAUSE_RUNS)})
    assert (j.verdict, j.cause) == ("inconclusive", CAUSE_READING)
    assert j.under("holds") == ["a"] and j.under("fails") == ["b"] and j.under("undecided") == ["c"]
    j = combine_readings({"a": _j(N), "b": Judgement("inconclusive", CAUSE_RUNS, 120),
                          "c": Judgement("inconclusive", CAUSE_RUNS, 300)})
    assert (j.verdict, j.cause, j.runs_needed) == ("inconclusive", CAUSE_RUNS, 300)
    assert combine_readings({"a": _j("inconclusive", CAUSE_TIE)}).cause == CAUSE_TIE
    assert combine_readings({"a": _j(R), "b": _j("inconclusive", CAUSE_TIE)}).cause == CAUSE_READING
    # fails under one reading, a tie under the other: it holds under none
    assert combine_readings({"a": _j(N), "b": _j("inconclusive", CAUSE_TIE)}).verdict == N
    j = combine_readings({"a": _j(N), "b": _j("inconclusive", CAUSE_TIE), "c": _j("inconclusive", CAUSE_RUNS)})
    assert (j.verdict, j.cause) == ("inconclusive", CAUSE_RUNS)  # the undecided reading could still hold


def test_excluded_readings_are_shown_not_counted():
    rd = {"ut=a": (1.0, 0.1, 50), "ut=b": (-1.0, 0.1, 50)}
    assert judge(diff=1.0, diff_se=0.1, reading_diffs=rd).cause == CAUSE_READING
    assert judge(diff=1.0, diff_se=0.1, reading_diffs=rd, excluded={"ut=b": "l.1: excluded"}).verdict == "reproduced"
    reg = ClaimsRegistry("p")
    c = reg.add("x", "A beats B", diff=1.0, diff_se=0.1, reading_diffs=rd, excluded={"ut=b": "l.1: excluded"})
    assert "not counted" in c.test_text() and "l.1: excluded" in c.test_text()
    with pytest.raises(ValueError, match="not readings of the claim"):
        reg.add("y", "A beats B", diff=1.0, diff_se=0.1, reading_diffs=rd, excluded={"ut=c": "?"})
    with pytest.raises(ValueError, match="every reading"):
        judge(diff=1.0, diff_se=0.1, reading_diffs={"ut=a": (1, 0.1)}, excluded={"ut=a": "x"})


def test_printed_effect_needs_differences_per_reading():
    with pytest.raises(ValueError, match="reading_diffs"):
        judge(diff=1.0, diff_se=0.1, readings={"a=1": True}, effect=0.5)
    with pytest.raises(ValueError, match="> 0"):
        judge(diff=1.0, diff_se=0.1, effect=-0.5)
    j = judge(diff=1.0, diff_se=0.1, effect=1.0, reading_diffs={"a=1": (1.0, 0.1, 40), "a=2": (0.5, 0.1, 40)})
    assert j.verdict == "qualitatively reproduced"  # size attained under one reading, direction under both


def test_published_number_under_readings_and_the_ordering():
    # matched under the main reading only; the ordering holds under every reading -> qualitatively
    j = judge(published=10, reproduced=10.2, se=0.5, reading_values={"q=2": (20, 0.5)},
              readings={"q=1": True, "q=2": True})
    assert j.verdict == "qualitatively reproduced"
    # matched under one reading, the ordering fails under the other -> depends on the reading
    j = judge(published=10, reproduced=10.2, se=0.5, reading_values={"q=2": (20, 0.5)},
              readings={"q=1": True, "q=2": False})
    assert (j.verdict, j.cause) == ("inconclusive", CAUSE_READING)
    # matched nowhere, ordering undecided: the ordering's cause
    j = judge(published=10, reproduced=20, se=0.5, diff=0.1, diff_se=0.1, runs=10, margin=0.25)
    assert (j.verdict, j.cause) == ("inconclusive", CAUSE_RUNS) and j.runs_needed


def test_cost_claims_and_causes_in_the_saved_row():
    assert judge(basis="count", qualitative=None).cause == CAUSE_COUNT
    reg = ClaimsRegistry("p")
    c = reg.add("a", "A beats B", diff=0.1, diff_se=0.1, runs=10, margin=0.25)
    row = c.as_row()
    assert (row["verdict"], row["cause"], row["runs_needed"]) == ("inconclusive", CAUSE_RUNS, c.runs_needed)
    assert c.verdict_text() == f"inconclusive (too few runs: {c.runs_needed} would decide)"


def test_causes_on_the_page_and_in_the_scorecard():
    from pfrepro.claims import cause_text, causes_table, inconclusive_table
    from pfrepro.findings import cause_sentence, findings_html

    reg = ClaimsRegistry("p")
    reg.add("num", "a number", published=10, reproduced=10.1, se=0.2, reading_values={"q=2": (20, 0.2)},
            readings={"q=1": True, "q=2": False})
    reg.add("runs", "A beats B", diff=0.1, diff_se=0.1, runs=12, margin=0.25)
    reg.add("read", "A beats C", diff=1.0, diff_se=0.1, reading_diffs={"a=1, b=1": (1.0, 0.1, 30),
                                                                        "a=2, b=1": (-1.0, 0.1, 30)})
    reg.add("ok", "A beats D", diff=1.0, diff_se=0.1)
    by = {c.claim_id: c for c in reg.claims}
    assert cause_text(by["num"]) == ("depends on the reading: the number is matched under the main reading; "
                                     "not matched under q=2")
    assert cause_text(by["runs"]) == f"too few runs (12 runs, {by['runs'].runs_needed} would decide)"
    assert cause_text(by["read"]) == "depends on the reading: holds under (a=1, b=1); fails under (a=2, b=1)"
    assert cause_text(by["ok"]) == ""
    # in HTML (the findings' running text) reading names are code, the main reading stays words
    assert cause_text(by["read"], as_html=True) == (
        'depends on the reading: holds under <code class="pf-reading">(a=1, b=1)</code>; '
        'fails under <code class="pf-reading">(a=2, b=1)</code>')
    assert "the main reading" in cause_text(by["num"], as_html=True)
    assert "<code" not in cause_text(by["runs"], as_html=True).split("under")[0]
    # too few runs under one reading: its own runs, not the main reading's
    c = reg.add("und", "A beats E", diff=1.0, diff_se=0.1, runs=100, margin=0.5,
                reading_diffs={"a=1": (1.0, 0.1, 100), "a=2": (0.3, 0.3, 25)})
    assert cause_text(c) == f"too few runs (undecided under a=2 on 25 runs, {c.runs_needed} would decide)"
    assert c.runs_needed > 25
    reg.claims.remove(c)
    t = causes_table(reg)
    assert t.loc["p", CAUSE_READING] == 2 and t.loc["p", CAUSE_RUNS] == 1 and t.loc["all claims", "inconclusive"] == 3
    assert inconclusive_table(reg)["id"].tolist() == ["num", "runs", "read"]
    assert cause_sentence(reg.claims) == "of the 3 inconclusive claims, 2 depend on the reading and 1 needs more runs"
    assert cause_sentence(reg.claims[:2]) == "of the 2 inconclusive claims, 1 depends on the reading and 1 needs more runs"
    assert cause_sentence(reg.claims[1:2]) == "the inconclusive claim needs more runs"
    assert cause_sentence(reg.claims[3:]) == ""
    html = findings_html(reg, ["runs"], "take away")
    assert "would decide" in html and "1 needs more runs" in html
