# SPDX-License-Identifier: GPL-3.0-or-later
"""A tiny stand-in for Blender's `bpy`, enough to run the job type's BAKE and RENDER Python
outside Blender (pipeline/flamenco/test). One scene "Scene", an armature "Armature" with actions
"walk" and "run", and a mesh "Body" of 3 vertices with the modifiers
[Armature (off), Sweep Deform (geometry nodes), Subdivision]. The evaluated mesh's vertex v at
frame f is (v, f, 10 * action index) — what a bake must write. SWEEP_DEFORM_STATE in the
environment sets the binding state (default BOUND); SWEEP_DEFORM_NO_EXTENSION=1 removes the
extension's property group."""
import os
import types


class _Node:
    def __init__(self, **kw):
        self.__dict__.update(kw)


class _NodeGroup(dict):
    pass


class _Modifier:
    def __init__(self, name, type, **kw):
        self.name, self.type = name, type
        self.show_viewport = self.show_render = True
        self.node_group = None
        self.object = None
        self.__dict__.update(kw)


class _Modifiers(list):
    def new(self, name, type):
        md = _Modifier(name, type)
        self.append(md)
        return md

    def move(self, a, b):
        self.insert(b, self.pop(a))


class _Vertices(list):
    def foreach_get(self, attr, out):
        assert attr == "co"
        for i, v in enumerate(self):
            for k in range(3):
                out[3 * i + k] = v[k]


class _Actions(dict):
    def get(self, name, default=None):
        return dict.get(self, name, default)


scene = _Node(name="Scene", frame_current=1)
actions = _Actions(walk=_Node(name="walk", index=1), run=_Node(name="run", index=2))
armature = _Node(name="Armature", type='ARMATURE', animation_data=_Node(action=actions["walk"]))
armature.animation_data_create = lambda: None
sweep_group = _NodeGroup(sweep_deform_group=1)
body = _Node(name="Body", type='MESH', data=_Node(vertices=_Vertices([(0, 0, 0)] * 3)))
body.modifiers = _Modifiers([
    _Modifier("Armature", 'ARMATURE', object=armature, show_viewport=False, show_render=False),
    _Modifier("Sweep Deform", 'NODES', node_group=sweep_group),
    _Modifier("Subdivision", 'SUBSURF'),
])
if os.environ.get("SWEEP_DEFORM_NO_EXTENSION") != "1":
    body.sweep_deform = _Node(state=os.environ.get("SWEEP_DEFORM_STATE", "BOUND"), armature=armature)


def _evaluated_mesh():
    subdivided = any(md.type == 'SUBSURF' and md.show_viewport for md in body.modifiers)
    n = 12 if subdivided else 3
    k = armature.animation_data.action.index
    return _Node(vertices=_Vertices([(v, scene.frame_current, 10 * k) for v in range(n)]))


def _evaluated_get(depsgraph):
    ev = _Node()
    ev.to_mesh = _evaluated_mesh
    ev.to_mesh_clear = lambda: None
    return ev


body.evaluated_get = _evaluated_get


def _frame_set(f):
    scene.frame_current = f


scene.frame_set = _frame_set


class _Objects(dict):
    def get(self, name, default=None):
        return dict.get(self, name, default)


data = _Node(objects=_Objects(Body=body, Armature=armature), actions=actions, scenes={"Scene": scene},
             filepath="/farm/shot.blend")
context = _Node(scene=scene, window=None, evaluated_depsgraph_get=lambda: "depsgraph")
ops = _Node(object=_Node(modifier_move_to_index=lambda **kw: None))
app = types.SimpleNamespace(background=True)
