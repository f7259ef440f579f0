# SPDX-License-Identifier: GPL-3.0-or-later
"""The F-curves that animate an ID, in Blender 4.3's legacy actions and 5.x's layered ones."""


def fcurve_collections(id_data):
    """The F-curve collections of `id_data`: its drivers, then its action's (for its slot)."""
    ad = id_data.animation_data
    if ad is None:
        return []
    out = [ad.drivers]
    act = ad.action
    if act is None:
        return out
    if hasattr(act, "fcurves") and not hasattr(act, "layers"):
        out.append(act.fcurves)  # Blender 4.3: a legacy action
        return out
    try:
        layers = act.layers
    except AttributeError:
        layers = []
    if len(layers) == 0 and hasattr(act, "fcurves"):
        out.append(act.fcurves)
    for layer in layers:
        for strip in layer.strips:
            bag = strip.channelbag(ad.action_slot) if ad.action_slot is not None else None
            if bag is not None:
                out.append(bag.fcurves)
    return out
