"""Against today's methods (issue 22): the paper chapters' small paired comparison."""
import numpy as np
import pytest

from pfrepro.experiments import cmspf_ning2011 as CMS
from pfrepro.experiments import today as TD
from pfrepro.metrics import mse
from pfrepro.montecarlo import run_monte_carlo


def test_against_today_on_the_chapters_truths_and_given_runs():
    """A given paper's method (the chapter's own run) gives the same table as running it here; the
    truths are the chapter's (checked through y_check); a wrong y is refused."""
    out = TD.against_today("cmspf_ning2011", runs=3)
    tab = out["table"]
    N = CMS.ASSUMPTIONS["N_table2"]
    assert list(tab.index) == [f"CMS-PF({N})", f"APF({N})", f"RPF({N})", f"EKF-prop. PF({N})", f"PFPF-EDH({N})"]
    assert tab.loc[f"RPF({N})", "evals/step"] == 2 * N and tab.loc[f"APF({N})", "evals/step"] == 4 * N
    assert set(tab["vs paper's (Holm)"].iloc[1:]) <= {"better", "worse", "no difference shown", "diverged"}
    m = CMS.model()
    mc = run_monte_carlo(m, {f"CMS-PF({N})": CMS.cms(m, N)}, CMS.T, 3, CMS.SEEDS["table2"])
    again = TD.against_today("cmspf_ning2011", runs=3, y_check=mc.sim.y,
                             given={f"CMS-PF({N})": mse(mc.x_true, mc.results[f"CMS-PF({N})"].x)})
    np.testing.assert_allclose(again["table"]["MSE"].to_numpy(), tab["MSE"].to_numpy())
    with pytest.raises(ValueError, match="not this benchmark"):
        TD.against_today("cmspf_ning2011", runs=3, y_check=mc.sim.y + 1.0)
    s = TD.sentence(out)
    assert out["best"] in s and "first 3 runs" in s
    html = TD.styled(out).to_html()
    # headers in words: no abbreviation of the internal table's columns reaches the page
    for h in ("model evaluations per step", "MSE (± SE)", "MSE / exact", "z of the difference",
              "against the paper&#x27;s method"):
        assert h in html.replace("'", "&#x27;"), h
    assert "evals/step" not in html and ">z<" not in html
    with pytest.raises(ValueError, match="unknown paper"):
        TD.spec("nope")
