"""The Blender scene of scripts/engine-cycles, built and rendered in `bpy`.

Run by scripts/engine-cycles inside Blender's Python module (PyPI `bpy`):

    python scripts/cycles_scene.py JOB.json

JOB.json holds the render settings, the output paths and, per render, the
`script` a Blender script `ssskit engine --engine blender --out-dir DIR`
wrote. Every subsurface material is the one that script makes: its
make_material() as the user runs it, nothing set beside it; every socket
and the method are then read back from the node and must be the script's
VALUES and METHOD. Only the unclaimed Random Walk (Skin) render passes
make_material() other values (the script's with Subsurface IOR) and
another method. The script writes one linear EXR per render (read with
the OpenEXR package: Blender's own image loader rounds the pixels it hands
back to Python to 1e-4) and a JSON of their timings.

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


# A socket holds 32-bit floats: what it reads back is the value to this.
FLOAT32_REL = 1e-6


def load_script(path):
    """The written script's globals (run as a module, not as __main__, so
    it defines make_material, VALUES and METHOD and makes nothing)."""
    import runpy

    return runpy.run_path(path, run_name="ssskit_material")


def same(a, b):
    """Two socket values (numbers or sequences) equal to float32."""
    a = list(a) if hasattr(a, "__len__") else [a]
    b = list(b) if hasattr(b, "__len__") else [b]
    return len(a) == len(b) and all(
        abs(x - y) <= FLOAT32_REL * max(abs(x), abs(y), 1e-30) for x, y in zip(a, b))


def socket_value(v, sock):
    """A job value as the socket takes it: an RGB list gets alpha 1 on a
    colour socket."""
    if isinstance(v, (list, tuple)):
        return list(v) + ([1.0] if len(sock.default_value) == 4 and len(v) == 3 else [])
    return v


def check_node(bsdf, values, method):
    """Reads every value back from the node: the script must have set
    what was asked for."""
    if bsdf.subsurface_method != method:
        sys.exit(f"material script: subsurface_method {bsdf.subsurface_method}, not {method}")
    for name, v in values.items():
        sock = bsdf.inputs[name]
        got = sock.default_value
        want = socket_value(v, sock)
        if not same(got, want):
            sys.exit(f"material script: {name} reads back {list(got) if hasattr(got, '__len__') else got}, "
                     f"not {want}")


def principled(render):
    """The slab's material, made by the written script `render["script"]`:
    its own VALUES and METHOD, or (an unclaimed variant) its values with
    `render["extra"]` and `render["method"]`; every socket read back."""
    mod = load_script(render["script"])
    values, method = dict(mod["VALUES"]), mod["METHOD"]
    if render.get("extra") or render.get("method", method) != method:
        values.update(render.get("extra", {}))
        method = render["method"]
        mat = mod["make_material"]("slab", values=values, method=method)
    else:
        mat = mod["make_material"]("slab")
    check_node(mod["principled_node"](mat), values, method)
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
    for r in job["renders"]:
        if r["material"] != "white" and not os.path.isfile(r.get("script", "")):
            sys.exit("each slab render needs `script`: the script `ssskit engine --engine "
                     "blender --out-dir DIR` wrote (DIR/NAME-blender.py)")
    times = {}
    for r in job["renders"]:
        job["seed"] = r["seed"]
        if r["material"] == "white":
            mat_fn = white
        else:
            def mat_fn():
                return principled(r)
        scene(job, None)
        # The material after the factory reset that scene() does.
        bpy.data.objects["slab"].data.materials.append(mat_fn())
        times[r["path"]] = render(r["path"])
        print(f"rendered {os.path.basename(r['path'])} in {times[r['path']]:.1f} s", flush=True)
    json.dump({"seconds": times, "blender": bpy.app.version_string},
              open(job["timing_out"], "w"), indent=1)


if __name__ == "__main__":
    main()
