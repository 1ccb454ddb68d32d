"""Table I's numbers: fixed decimals per metric, the same for the mean and its standard error."""

import json
import re

from sim.campaign import ROWS, Run, WorldSpec, cell, table_markdown


def test_a_cell_has_the_same_fixed_decimals_for_mean_and_error():
    # the examples: "71.64 ± 12" and "99.99 ± 0.00046" (coverage, %)
    assert cell({"mean": 71.64, "stderr": 12.0, "n": 4}, 4, 1) == "71.6 ± 12.0"
    assert cell({"mean": 99.99, "stderr": 0.00046, "n": 4}, 4, 1) == "100.0 ± 0.0"
    assert cell({"mean": 0.94712, "stderr": 0.0171, "n": 3}, 4, 3) == "0.947 ± 0.017 (n=3)"
    assert cell({"mean": 6169.4, "stderr": 430.2, "n": 4}, 4, 0) == "6169 ± 430"
    assert cell({"mean": -0.00001, "stderr": 0.0, "n": 4}, 4, 2) == "0.00 ± 0.00"   # no "-0.00"
    assert cell({"mean": None, "stderr": None, "n": 0}, 4, 1) == "—"


def metrics(seed: int) -> dict:
    return {"world": "room", "method": "gp", "seed": seed, "termination_reason": "frontiers_exhausted",
            "travel_distance_m": 71.64 + 20 * seed, "sim_time_s": 430.3 + seed, "wall_time_s": 81.63,
            "final_map_entropy_nats": 6857.4 + 100 * seed, "entropy_rate_nats_per_step": -3.0537,
            "coverage": 0.9999 - 1e-5 * seed, "auc": 0.96594 + 0.01 * seed, "ate_rmse_m": 0.21713,
            "collisions": seed, "travel_at_coverage_m": {"0.90": 40.0, "0.95": 50.55, "0.99": None}}


def test_table_markdown_prints_fixed_decimals_per_metric(tmp_path):
    runs = []
    for seed in range(3):
        folder = tmp_path / "room" / "gp" / f"seed_{seed}"
        folder.mkdir(parents=True)
        (folder / "metrics.json").write_text(json.dumps(metrics(seed)))
        runs.append(Run(WorldSpec("room", (0.0, 0.0, 0.0)), {"stack": {"explorer": {"method": "gp"}}},
                        seed, str(folder)))
    lines = {line.split(" | ")[0].lstrip("| "): line for line in table_markdown(runs).splitlines()
             if line.startswith("| ") and "±" in line}
    expected = {"Travel distance (m)": 1, "Exploration time (min)": 1, "Map entropy rate (nats/step)": 2,
                "Final map entropy (nats)": 0, "Coverage (%)": 1, "AUC": 3, "Travel at 90 % coverage (m)": 1,
                "ATE RMSE (m)": 3, "Collisions": 1, "Wall time (s)": 1}
    assert set(expected) <= {label for label, _, _ in ROWS}
    for label, decimals in expected.items():
        number = r"-?\d+" + (rf"\.\d{{{decimals}}}" if decimals else "")
        assert re.search(rf"\| {number} ± {number} \|$", lines[label]), lines[label]
    assert "| Coverage (%) | 100.0 ± 0.0 |" in lines["Coverage (%)"]
    assert "| Travel distance (m) | 91.6 ± 11.5 |" in lines["Travel distance (m)"]
