"""The example room, built in Blender 4.2 (the `bpy` package) and exported as USD and glTF.

Run with Blender as a module (not a dependency of attenfit; about 0.5 GB):
`pip install "bpy==4.2.*"`, then `python make_room.py examples/scenes/blender`.
"""

import math
import sys

import bpy

out = sys.argv[-1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def plane(name, size, loc, rot=(0, 0, 0)):
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
    ob = bpy.context.active_object
    ob.name = name
    ob.data.name = name
    return ob


plane("Floor", 8.0, (0, 0, 0))
# a wall 4 m to the back, facing the room (+Y normal after the rotation)
plane("BackWall", 8.0, (0, 4, 2), rot=(math.radians(90), 0, 0))
bpy.ops.mesh.primitive_cube_add(size=1.0, location=(1.2, 0.8, 0.4))
table = bpy.context.active_object
table.name = "Table"
table.scale = (1.2, 0.7, 0.4)
bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)

# a bulb hung from a rig (an empty rotated and moved: nested transforms)
rig = bpy.data.objects.new("Rig", None)
scene.collection.objects.link(rig)
rig.location = (-1.0, -0.5, 2.0)
rig.rotation_euler = (0, 0, math.radians(30))
bulb = bpy.data.lights.new("Bulb", type="POINT")
bulb.energy = 60.0
bulb.shadow_soft_size = 0.08
ob = bpy.data.objects.new("Bulb", bulb)
scene.collection.objects.link(ob)
ob.parent = rig
ob.location = (0.0, 0.0, 0.6)

spot = bpy.data.lights.new("Spot", type="SPOT")
spot.energy = 200.0
spot.shadow_soft_size = 0.05
spot.spot_size = math.radians(60)
spot.spot_blend = 0.3
ob = bpy.data.objects.new("Spot", spot)
scene.collection.objects.link(ob)
ob.location = (1.5, -1.0, 3.0)
ob.rotation_euler = (math.radians(-25), 0, 0)

panel = bpy.data.lights.new("Panel", type="AREA")
panel.shape = "DISK"
panel.size = 0.6
panel.energy = 150.0
ob = bpy.data.objects.new("Panel", panel)
scene.collection.objects.link(ob)
ob.location = (-1.5, 2.0, 3.2)

strip = bpy.data.lights.new("Strip", type="AREA")
strip.shape = "RECTANGLE"
strip.size, strip.size_y = 1.0, 0.1
strip.energy = 40.0
ob = bpy.data.objects.new("Strip", strip)
scene.collection.objects.link(ob)
ob.location = (2.5, 3.5, 3.0)

bpy.ops.wm.usd_export(
    filepath=f"{out}/room.usda",
    export_lights=True,
    export_materials=False,
    export_normals=True,
    selected_objects_only=False,
)
bpy.ops.export_scene.gltf(
    filepath=f"{out}/room.glb",
    export_format="GLB",
    export_lights=True,
    export_materials="NONE",
    export_yup=True,
)
print("exported", bpy.app.version_string)
