"""pfrepro.prose: the chapters' glue helpers and generated sentences in number agreement."""
import numpy as np

from pfrepro import prose


def test_plural_and_count_is():
    assert prose.plural(1, "claim") == "1 claim"
    assert prose.plural(0, "claim") == "0 claims"
    assert prose.plural(2, "entry", "entries") == "2 entries"
    assert prose.count_is(1, "reproduced") == "1 is reproduced"
    assert prose.count_is(0, "reproduced") == "0 are reproduced"
    assert prose.count_is(3, "reproduced") == "3 are reproduced"


def test_join_and():
    import pytest

    assert prose.join_and(["a"]) == "a"
    assert prose.join_and(["a", "b"]) == "a and b"
    assert prose.join_and(x for x in "abc") == "a, b and c"
    with pytest.raises(ValueError):
        prose.join_and([])


def test_verdict_sentence_agrees_in_number():
    s = prose.verdict_sentence(["reproduced", "inconclusive", "inconclusive"])
    assert s == ("Of 3 claims, 1 is reproduced, 0 are qualitatively reproduced, 0 are not reproduced "
                 "and 2 are inconclusive")
    assert "1 are" not in prose.verdict_sentence({"reproduced": 1, "not reproduced": 1})
    assert prose.verdict_sentence(["not checkable"], noun="recorded claim").startswith("Of 1 recorded claim,")
    assert prose.verdict_sentence(["not checkable"]).endswith("and 1 is not checkable")


def test_glue_helpers_return_nothing(monkeypatch):
    """A glue call that ends a notebook cell must not add an output to the page."""
    import myst_nb

    seen = []
    monkeypatch.setattr(myst_nb, "glue", lambda name, value, display=True: seen.append((name, value, display)))
    assert prose.glue_value("a", np.float64(0.5)) is None
    assert prose.glue_md("b", "*x*") is None
    assert seen[0] == ("a", 0.5, False) and type(seen[0][1]) is float
    assert seen[1][0] == "b" and seen[1][2] is False


def test_tables_show_missing_values_as_a_dash_and_whole_cells():
    import pandas as pd

    html = prose._frame_html(pd.DataFrame({"a": [1.0, np.nan], "reason": ["x" * 80, "y"]}))
    assert "NaN" not in html and "nan" not in html and prose.MISSING in html
    assert "x" * 80 in html and "..." not in html


def test_numbers_are_never_broken_and_styler_nan_is_a_dash():
    import pandas as pd

    df = pd.DataFrame({"a": [3.2e-14, np.nan]})
    html = prose._styler_html(df.style.format("{:.2e}"))
    assert '<span class="pf-num">3.20e-14</span>' in html
    assert ">nan<" not in html and prose.MISSING in html
