# SPDX-License-Identifier: GPL-3.0-or-later
"""Reading the fitting's JSON report (``sd_fit_result_report``): plain Python, no ``bpy``.

The report is kept in the bound object (persistence.REPORT_KEY). Its chains name the limbs in
the panel (:func:`sweep_labels`), give the elbows and knees of the anatomical effects
(:func:`report_joints`), and its warnings are told to the user after binding
(:func:`report_warnings`). A damaged or missing report gives empty answers, never an error.
"""

import json
import math


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
    direction)] from its arm and leg chains that got a sweep (their last link is the joint's
    lower link: the first bone of a forearm or shin cut in two, as Rigify's DEF-forearm.L /
    .001; a report from before links were reported gives the chain's last bone); the flexion
    direction is the body's forward for an elbow, its back for a knee (armature space, as the
    report's body axes)."""
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
            names = ch.get("link_names") or ch.get("bone_names", [])
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


#: What the automatic fitting is made for (docs/addon.md, "Supported rigs").
SUPPORTED_RIGS = ("Sweep Deform fits humanoid rigs only (a torso, two arms, two legs, and a neck or head, "
                  "bones in any naming)")
#: A leg must point away from the head: at most this angle (degrees) from the body's down.
LEG_ANGLE_LIMIT = 60.0


def humanoid_problem(report, heads, tails, bone_names=()):
    """None if the fitting report describes a humanoid, else what was not found, naming the
    bones: a torso, two arms, two legs pointing away from the head (a quadruped's hind legs
    stand at right angles to its spine), a neck or head. `heads`, `tails` (B,3) in armature
    space as given to the fitting."""
    try:
        r = json.loads(report) if report else {}
        chains = list(r.get("chains", []))
        up = [float(x) for x in r.get("body", {}).get("up", ())]
    except (ValueError, AttributeError, TypeError):
        return "the fitting gave no readable description of the skeleton"

    def name(b):
        return f"'{bone_names[b]}'" if 0 <= b < len(bone_names) else f"bone {b}"

    kinds = {}
    for ch in chains:
        if isinstance(ch, dict):
            kinds.setdefault(ch.get("kind"), []).append(ch)
    missing = []
    if not kinds.get("torso"):
        missing.append("a torso")
    arms, legs = kinds.get("arm", []), kinds.get("leg", [])
    if len(arms) != 2:
        missing.append(f"two arms (found {len(arms)})")
    if len(legs) != 2:
        missing.append(f"two legs (found {len(legs)})")
    torso = (kinds.get("torso") or [{}])[0]
    if not kinds.get("neck") and torso.get("end_bone", -1) < 0:
        missing.append("a neck or head above the arms")
    if missing:
        return "no humanoid found: the skeleton has no " + ", no ".join(missing)
    if len(up) != 3 or not all(abs(x) < 1e30 for x in up):
        return "no humanoid found: the skeleton has no direction from its hips to its head"
    norm = math.sqrt(sum(x * x for x in up)) or 1.0
    up = [x / norm for x in up]
    for leg in legs:
        bones = [b for b in leg.get("bones", []) if isinstance(b, int) and 0 <= b < len(heads)]
        if not bones:
            continue
        start, end = heads[bones[0]], tails[bones[-1]]
        d = [float(end[i]) - float(start[i]) for i in range(3)]
        length = math.sqrt(sum(x * x for x in d))
        if length <= 0.0:
            continue
        down = -sum(d[i] * up[i] for i in range(3)) / length
        angle = math.degrees(math.acos(max(-1.0, min(1.0, down))))
        if angle > LEG_ANGLE_LIMIT:
            return (f"no humanoid legs: the leg {name(bones[0])}–{name(bones[-1])} points {angle:.0f}° away "
                    f"from the body's down (hips to head reversed; a humanoid's legs are within "
                    f"{LEG_ANGLE_LIMIT:.0f}°): a four-legged or lying rig?")
    return None


def humanoid_refusal(problem):
    """The sentence the user gets for a rig that is not a humanoid."""
    end = "" if problem.endswith(("?", ".")) else "."
    return f"{SUPPORTED_RIGS}; {problem}{end} Nothing was changed"
