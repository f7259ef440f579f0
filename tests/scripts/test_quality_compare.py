# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/quality_compare.py on two runs written by hand: which of issue 14's criteria a change
won and lost, which tests moved, and what it refuses."""

import json
import os
import sys

import pytest

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import quality_compare  # noqa: E402


def record(pairs=0, crease=10.0, volume=-0.5, section=1.0, r_max=1.05):
    return {"status": "ok", "selfint": {"pose": {"pairs": pairs}}, "crease": {"crease_new_deg_p999": crease},
            "volume": {"dV_region_pct": volume}, "cross_section": {"min_ratio": section},
            "axis_distance_ratio": {"max": r_max}}


def write(run, body, method, tests):
    d = os.path.join(run, "4.3", body)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, method + ".json"), "w") as f:
        json.dump({"tests": tests}, f)


@pytest.fixture
def runs(tmp_path):
    before, after = str(tmp_path / "before"), str(tmp_path / "after")
    reference = {"spine_bend_45": record(r_max=1.07, volume=-9.0), "elbow_flex_150": record(pairs=60),
                 "neck_twist_60": record(r_max=1.0)}
    write(before, "body", "lbs", reference)
    write(before, "body", "dqs", reference)
    write(before, "body", "sweep", {"spine_bend_45": record(r_max=1.11), "elbow_flex_150": record(pairs=55),
                                    "neck_twist_60": record(r_max=1.0)})
    write(after, "body", "sweep", {"spine_bend_45": record(r_max=1.06), "elbow_flex_150": record(pairs=64),
                                   "neck_twist_60": record(r_max=1.0)})
    return before, after


def test_a_change_wins_and_loses_criteria_test_by_test(runs):
    # LBS and DQS come from the run that has them (before); Sweep from each.
    lines, misses = quality_compare.compare(*runs, "4.3")
    assert "body spine_bend_45: pairs 0, crease 10°, volume -0.50 %, section 1.000, r_max 1.1100 → 1.0600  WON r_max" \
        in lines
    assert "body elbow_flex_150: pairs 55 → 64, crease 10°, volume -0.50 %, section 1.000, r_max 1.0500  LOST pairs" \
        in lines
    assert misses == {"before": {"r_max": 1}, "after": {"pairs": 1}}


def test_tests_that_did_not_move_are_left_out_unless_asked(runs):
    assert not any("neck_twist_60" in line for line in quality_compare.compare(*runs, "4.3")[0])
    assert any(line.startswith("body neck_twist_60:") for line in quality_compare.compare(*runs, "4.3", True)[0])


def test_a_body_missing_from_the_first_run_is_said_not_dropped(runs):
    before, after = runs
    write(after, "newcomer", "sweep", {"spine_bend_45": record()})
    assert "newcomer: not in both runs with LBS and DQS, skipped" in quality_compare.compare(before, after, "4.3")[0]


def test_a_directory_that_is_not_a_run_is_refused(runs, capsys):
    with pytest.raises(SystemExit) as e:
        quality_compare.main([runs[0], "/nonexistent", "--use", "4.3"])
    assert e.value.code == 2 and "no Blender 4.3 results" in capsys.readouterr().err
