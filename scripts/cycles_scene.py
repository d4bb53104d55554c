"""The Blender scene of scripts/engine-cycles, built and rendered in `bpy`.

Run by scripts/engine-cycles inside Blender's Python module (PyPI `bpy`):

    python scripts/cycles_scene.py JOB.json

JOB.json holds the Principled BSDF values to type (under the node's socket
names), the render settings and the output path; the script writes one
linear EXR per render (read with the OpenEXR package: Blender's own
image loader rounds the pixels it hands back to Python to 1e-4) and a
JSON of their timings.

The scene (all in scene units, 1 unit = 1 metre as Blender's default):
a thick slab whose top face is the plane z = 0, an orthographic camera
looking straight down, a sun at the zenith (angle 0: a sharp shadow) and
an occluder above the half-plane x < 0 that only shadow rays see, so the
slab is lit for x > 0 and what reaches x < 0 is light that scattered
under the surface: the edge (step) response of the subsurface profile.
A white Lambertian render of the same scene gives the irradiance scale
(E / pi for albedo 1).
"""

import json
import os
import sys
import time

import bpy

SLAB_HALF = 0.25  # m: far beyond any profile's reach
SLAB_DEPTH = 0.1  # m: "thick" for every material scored (1/sigma_tr < 15 mm)
OCCLUDER_HEIGHT = 0.01  # m above the slab


def clear():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def box(name, lo, hi):
    import bmesh

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    for v in bm.verts:
        v.co.x = lo[0] if v.co.x < 0 else hi[0]
        v.co.y = lo[1] if v.co.y < 0 else hi[1]
        v.co.z = lo[2] if v.co.z < 0 else hi[2]
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def principled(values, method):
    mat = bpy.data.materials.new("slab")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = nodes.get("Principled BSDF")
    bsdf.subsurface_method = method
    # Only the subsurface layer: no specular, coat, sheen, metal or
    # transmission (each takes its share of the weight, closure.h).
    fixed = {
        "Metallic": 0.0,
        "Specular IOR Level": 0.0,
        "Coat Weight": 0.0,
        "Sheen Weight": 0.0,
        "Transmission Weight": 0.0,
        "Roughness": 0.0,
    }
    fixed.update(values)
    for name, v in fixed.items():
        sock = bsdf.inputs[name]
        if isinstance(v, list):
            sock.default_value = list(v) + ([1.0] if len(sock.default_value) == 4 else [])
        else:
            sock.default_value = v
    return mat


def white():
    mat = bpy.data.materials.new("white")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    d = nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    d.inputs["Roughness"].default_value = 0.0
    mat.node_tree.links.new(d.outputs["BSDF"], out.inputs["Surface"])
    return mat


def scene(job, material):
    clear()
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = int(job["spp"])
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = int(job["seed"])
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.max_bounces = 4
    cy.diffuse_bounces = 2
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 0
    cy.caustics_reflective = False
    cy.caustics_refractive = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.threads_mode = "FIXED"
    sc.render.threads = int(job["threads"])
    sc.render.resolution_x = int(job["width_px"])
    sc.render.resolution_y = int(job["height_px"])
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = False
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.image_settings.exr_codec = "ZIP"

    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    sc.world = world

    slab = box("slab", (-SLAB_HALF, -SLAB_HALF, -SLAB_DEPTH), (SLAB_HALF, SLAB_HALF, 0.0))
    if material is not None:
        slab.data.materials.append(material)

    occ = box("occluder", (-2 * SLAB_HALF, -2 * SLAB_HALF, OCCLUDER_HEIGHT),
              (0.0, 2 * SLAB_HALF, OCCLUDER_HEIGHT + 0.001))
    occ.visible_camera = False
    occ.visible_diffuse = False
    occ.visible_glossy = False
    occ.visible_transmission = False
    occ.visible_volume_scatter = False
    occ.visible_shadow = True

    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = 1.0  # W/m^2 of irradiance
    sun_data.angle = 0.0
    sun = bpy.data.objects.new("sun", sun_data)
    sc.collection.objects.link(sun)  # default orientation: shining down -z

    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = float(job["width_m"])  # the image's longer side
    cam_data.clip_start = 0.001
    cam_data.clip_end = 10.0
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = (0.0, 0.0, 1.0)  # looks down -z, up = +y: columns are x
    sc.collection.objects.link(cam)
    sc.camera = cam


def render(path):
    """Renders to the linear EXR at `path`; returns the seconds it took."""
    sc = bpy.context.scene
    sc.render.filepath = path
    t = time.time()
    bpy.ops.render.render(write_still=True)
    return time.time() - t


def main():
    job = json.load(open(sys.argv[1]))
    times = {}
    for r in job["renders"]:
        job["seed"] = r["seed"]
        if r["material"] == "white":
            mat_fn = white
        else:
            def mat_fn():
                return principled(r["values"], r["method"])
        scene(job, None)
        # The material after the factory reset that scene() does.
        bpy.data.objects["slab"].data.materials.append(mat_fn())
        times[r["path"]] = render(r["path"])
        print(f"rendered {os.path.basename(r['path'])} in {times[r['path']]:.1f} s", flush=True)
    json.dump({"seconds": times, "blender": bpy.app.version_string},
              open(job["timing_out"], "w"), indent=1)


if __name__ == "__main__":
    main()
