"""The fitting report as the add-on reads it (core/fit_report.py), on reports written by hand: the
elbows and knees the anatomical effects are set on."""

import json

import addon_modules

fit_report = addon_modules.import_core("fit_report")


def report(*chains):
    return json.dumps({"body": {"forward": [0.0, -1.0, 0.0]}, "chains": list(chains)})


def test_the_elbow_is_the_last_link_not_the_last_bone():
    """A forearm cut in two (Rigify's DEF-forearm.L / .001) is one link, whose first bone is the
    elbow's lower link: the last bone, the forearm's second half, has no joint key."""
    joints = fit_report.report_joints(report(
        {"name": "arm_l", "kind": "arm", "side": 1, "sweep": 2,
         "bone_names": ["clavicle_l", "upperarm_l", "upperarm_l.001", "lowerarm_l", "lowerarm_l.001"],
         "link_names": ["upperarm_l", "lowerarm_l"]},
        {"name": "leg_r", "kind": "leg", "side": -1, "sweep": 4,
         "bone_names": ["thigh_r", "calf_r"], "link_names": ["thigh_r", "calf_r"]},
        {"name": "leg_l", "kind": "leg", "side": 1, "sweep": -1,  # no sweep: no knee
         "bone_names": ["thigh_l", "calf_l"], "link_names": ["thigh_l", "calf_l"]}))
    assert [(label, bone, kind) for label, bone, kind, _ in joints] == [
        ("Elbow L", "lowerarm_l", 'ELBOW'), ("Knee R", "calf_r", 'KNEE')]
    assert joints[0][3] == [0.0, -1.0, 0.0] and joints[1][3] == [-0.0, 1.0, -0.0]  # a knee flexes back


def test_a_report_from_before_links_gives_the_last_bone():
    """Files bound before the report named its links keep their elbows."""
    joints = fit_report.report_joints(report(
        {"name": "arm_r", "kind": "arm", "side": -1, "sweep": 3,
         "bone_names": ["clavicle_r", "upperarm_r", "lowerarm_r"]}))
    assert [(label, bone) for label, bone, _, _ in joints] == [("Elbow R", "lowerarm_r")]
