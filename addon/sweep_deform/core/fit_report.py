# SPDX-License-Identifier: GPL-3.0-or-later
"""Reading the fitting's JSON report (``sd_fit_result_report``): plain Python, no ``bpy``.

The report is kept in the bound object (persistence.REPORT_KEY). Its chains name the limbs in
the panel (:func:`sweep_labels`), give the elbows and knees of the anatomical effects
(:func:`report_joints`), and its warnings are told to the user after binding
(:func:`report_warnings`). A damaged or missing report gives empty answers, never an error.
"""

import json


def sweep_labels(key_bones, bone_names, report=""):
    """A readable name per sweep: the fitting report's chain name ("arm_l") when there is one,
    else the bones its keys follow ("upperarm_l – lowerarm_l")."""
    named = {}
    if report:
        try:
            for chain in json.loads(report).get("chains", []):
                if chain.get("sweep", -1) >= 0 and chain.get("name"):
                    named[chain["sweep"]] = chain["name"]
        except (ValueError, AttributeError, TypeError):
            named = {}
    labels = []
    for s, bones in enumerate(key_bones):
        if s in named:
            labels.append(named[s])
            continue
        seen = []
        for b in bones:
            if 0 <= b < len(bone_names) and bone_names[b] not in seen:
                seen.append(bone_names[b])
        if len(seen) > 3:
            seen = [seen[0], "…", seen[-1]]
        labels.append(" – ".join(seen) if seen else "sweep")
    return labels


def report_joints(report):
    """The elbows and knees of a fitting report: [(label, lower bone name, kind, flexion
    direction)] from its arm and leg chains that got a sweep (their last bone is the joint's
    lower link); the flexion direction is the body's forward for an elbow, its back for a
    knee (armature space, as the report's body axes)."""
    try:
        r = json.loads(report) if report else {}
        forward = [float(x) for x in r.get("body", {}).get("forward", (0.0, -1.0, 0.0))]
        chains = r.get("chains", [])
    except (ValueError, AttributeError, TypeError):
        return []
    joints = []
    for ch in chains:
        try:
            kind = {"arm": 'ELBOW', "leg": 'KNEE'}.get(ch.get("kind"))
            names = ch.get("bone_names", [])
            if kind is None or ch.get("sweep", -1) < 0 or len(names) < 2:
                continue
            side = ch.get("side", 0)
            suffix = {1: " L", -1: " R"}.get(side, "") if isinstance(side, int) else ""
            label = ("Elbow" if kind == 'ELBOW' else "Knee") + (suffix or f" ({ch.get('name', names[-1])})")
            direction = forward if kind == 'ELBOW' else [-x for x in forward]
            joints.append((label, names[-1], kind, direction))
        except (AttributeError, TypeError):
            continue
    return joints


def report_warnings(report):
    """The fitting report's warnings and failed chains, as short sentences."""
    try:
        r = json.loads(report) if report else {}
    except ValueError:
        return []
    lines = list(r.get("warnings", []))
    for chain in r.get("chains", []):
        if chain.get("sweep", 0) < 0 or "error" in chain:
            lines.append(f"chain {chain.get('name', '?')} got no sweep: {chain.get('error', 'not fitted')}")
    return lines
