"""Blender Cycles renders `ssskit engine --engine blender`'s values.

Run by scripts/engine-cycles (which makes the virtual environment); see
there for the options. For each material and subsurface method, Cycles
(PyPI `bpy`, CPU) renders the scene of scripts/cycles_scene.py: a thick
slab lit by a sun at the zenith, half of it in the sharp shadow of an
occluder the camera does not see, seen from above by an orthographic
camera. Averaged over the image's rows, the render divided by a white
Lambertian render of the same scene (E / pi) is the slab's edge response:
the diffuse reflectance from the lit half-plane x > 0,

    E(x) = integral over x' > 0 of R_d(|p - p'|) dA'.

Of a radial profile R_d(r) it is, for the mass M(a) lying beyond a line at
distance a from the centre, E(x) = M(-x) for x < 0 and total - M(x) for
x > 0, with M(a) = integral_a^inf R_d(r) 2 r acos(a / r) dr; on annular
bins of constant R_d that integral is closed: F(r) = r^2 / 2 acos(a / r)
- a / 2 sqrt(r^2 - a^2) has F'(r) = r acos(a / r). Each pixel's
prediction is E averaged over the pixel (the render's box filter).

Scored per channel, as the RMS over the image's columns of the difference
of two edge responses, in % of the material's total reflectance (the
height of the step):

- claimed: the profile ssskit says Cycles renders against the material's
  profile (profiles/reference/NAME.json, Monte Carlo);
- rendered: Cycles' render (the mean of two seeds) against the material;
- render vs claim: the render against the profile ssskit says it renders;
- noise: the RMS standard error of that mean of two renders, per column,
  from their difference; for a Random Walk claim (ssskit's Monte Carlo of
  Cycles' walk) combined in quadrature with the claim's own, from the
  difference of its two independent halves; "beyond noise" is
  sqrt(RMS^2 - noise^2).

A claim agrees with the render when the render's RMS against it is within
AGREE_FACTOR times the noise (the RMS of pure noise over N columns
scatters by about sqrt(1 / (2 N)) of itself: 5% at 200 columns; the
factor leaves room for the noise estimate from only two renders).

The colour: the mean of the render over the lit plateau (the columns
beyond PLATEAU of the half width, where the edge response is within a few
percent of the total) against the material's edge response there, signed:
what a user sees as the material's colour, darker or lighter.

Every slab is the material the Blender script `ssskit engine --out-dir`
writes makes (scripts/cycles_scene.py runs it): Christensen-Burley's
script from `--subsurface-method christensen-burley`, Random Walk's from
the default; Random Walk (Skin) runs the Random Walk script's
make_material() with that method and Subsurface IOR = the material's eta.
"""

import argparse
import datetime
import json
import math
import os
import resource
import shlex
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "scripts", "cycles_scene.py")

# The render agrees with a claim when its RMS against it is within this
# factor of the noise (see the module comment).
AGREE_FACTOR = 1.25
# Half the image's width, in units of the material's longest diffusion
# length 1 / sigma_tr: the edge response falls as exp(-sigma_tr x), to
# e^-4 = 2% of the step at the image's edge.
HALF_WIDTH_DIFFUSION_LENGTHS = 4.0
# The white render's columns are 0 left of the edge and E / pi right of it
# to this fraction of E / pi: a sample on the edge itself (x = 0 in float32
# a metre from the camera) lands on either side; measured 2e-4.
WHITE_STEP_TOL = 1e-3
# Samples per pixel column averaged for the box filter.
SUBPIXELS = 16
# The lit plateau, for the colour: the columns beyond this fraction of the
# half width (3.2 diffusion lengths and more from the edge).
PLATEAU = 0.8
# Blender's units: metres (its default): 0.001 scene units per mm.
UNITS_PER_MM = 0.001


def machine_line():
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        load = open("/proc/loadavg").read().split()[0]
    except OSError:
        load = "?"
    return f"{cpu}, {os.cpu_count()} logical cores, load average {load} at the start"


# ---------------------------------------------------------------- profiles


def mass_beyond(edges, rd, a):
    """M(a) for a profile constant on annuli [edges[i], edges[i+1]]."""
    a = np.abs(np.asarray(a, dtype=float))[:, None]
    r0 = edges[None, :-1]
    r1 = edges[None, 1:]

    def F(r):
        r = np.maximum(r, a)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(r > 0, np.clip(a / np.where(r > 0, r, 1.0), 0.0, 1.0), 1.0)
        return 0.5 * r * r * np.arccos(ratio) - 0.5 * a * np.sqrt(np.maximum(r * r - a * a, 0.0))

    return (2.0 * rd[None, :] * (F(r1) - F(r0))).sum(axis=1)


def edge_response(edges, rd, total, x):
    """E(x) for the lit half-plane x > 0 (x in mm)."""
    x = np.asarray(x, dtype=float)
    m = mass_beyond(edges, rd, x)
    return np.where(x < 0, m, total - m)


def pixel_edge(edges, rd, total, columns_mm):
    """E averaged over each pixel column [lo, hi)."""
    lo, hi = columns_mm
    t = (np.arange(SUBPIXELS) + 0.5) / SUBPIXELS
    xs = lo[:, None] + (hi - lo)[:, None] * t[None, :]
    return edge_response(edges, rd, total, xs.ravel()).reshape(xs.shape).mean(axis=1)


def burley_bins(albedo, d_mm, truncate_d=None):
    """Christensen and Burley 2015 normalized diffusion, A (e^{-r/d} +
    e^{-r/3d}) / (8 pi d r), as annulus means from its radial CDF
    1 - e^{-r/d} / 4 - 3 e^{-r/(3d)} / 4, on a geometric grid; with
    `truncate_d`, zero from that many d on and the rest renormalised (as
    ssskit's `Burley::bins`)."""
    def cdf(r):
        return 1.0 - 0.25 * np.exp(-r / d_mm) - 0.75 * np.exp(-r / (3.0 * d_mm))

    edges = np.concatenate([[0.0], np.geomspace(d_mm / 200.0, 120.0 * d_mm, 3000)])
    if truncate_d is not None:
        edges = np.concatenate([[0.0], np.geomspace(d_mm / 200.0, truncate_d * d_mm, 3000)])
    area = np.pi * np.diff(edges ** 2)
    k = 1.0 if truncate_d is None else 1.0 / cdf(truncate_d * d_mm)
    return edges, albedo * k * np.diff(cdf(edges)) / area, albedo


# ------------------------------------------------------------ Random Walk


def walk_claim(fit, cols):
    """The edge response of the Random Walk profile ssskit says Cycles
    renders (`ssskit engine --subsurface-method random-walk`, its "walk": two
    independent halves of its Monte Carlo of Cycles' walk): their mean
    and the standard error of that mean per column, per channel."""
    w = fit["walk"]
    mean, err = [], []
    for c in range(3):
        edges = np.array(w["r_edges_mm"][c])
        h = [pixel_edge(edges, np.array(w["rd_halves"][k][c]), w["total_halves"][k][c], cols)
             for k in (0, 1)]
        mean.append(0.5 * (h[0] + h[1]))
        err.append(0.5 * (h[0] - h[1]))
    return mean, err



# ---------------------------------------------------------------- running


def ssskit(args, binary):
    subprocess.run([binary] + args, check=True, stdout=subprocess.DEVNULL)


def read_rgb(path):
    import OpenEXR

    ch = OpenEXR.File(path).channels()
    px = ch["RGBA"].pixels if "RGBA" in ch else np.stack(
        [ch[k].pixels for k in "RGB"], axis=-1)
    return np.asarray(px, dtype=np.float64)[..., :3]


def columns(width_mm, width_px):
    lo = -0.5 * width_mm + width_mm * np.arange(width_px) / width_px
    return lo, lo + width_mm / width_px


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--materials", default="skin1,marble,ketchup")
    ap.add_argument("--methods", default="burley,random-walk,random-walk-skin")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--width-px", type=int, default=200)
    ap.add_argument("--height-px", type=int, default=40)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "ssskit"))
    ap.add_argument("--record", default=os.path.join(ROOT, "docs", "records",
                                                     "engine-cycles.json"))
    ap.add_argument("--keep", help="keep the renders in this folder")
    a = ap.parse_args()
    machine = machine_line()
    tmp = a.keep or tempfile.mkdtemp(prefix="engine-cycles-")
    os.makedirs(tmp, exist_ok=True)
    rows, data, render_cpu = [], {}, {}
    started = time.time()
    cpu_started = children_cpu()
    for name in a.materials.split(","):
        prof_path = os.path.join(ROOT, "profiles", "reference", f"{name}.json")
        prof = json.load(open(prof_path))
        layer = prof["material"]["layers"][0]
        if len(prof["material"]["layers"]) != 1 or len(set(layer["g"])) != 1:
            sys.exit(f"{name}: one layer with one g is what Cycles' walk takes")
        scripts, fits = {}, {}
        for key, flags in (("cb", ["--subsurface-method", "christensen-burley"]), ("rw", [])):
            out = os.path.join(tmp, f"{name}-{key}.json")
            files = os.path.join(tmp, f"{name}-{key}-files")
            if key == "rw" and not any(m.startswith("random-walk")
                                       for m in a.methods.split(",")):
                continue
            ssskit(["engine", "--profile", prof_path, "--engine", "blender", *flags,
                    "--out", out, "--out-dir", files], a.bin)
            fits[key] = json.load(open(out))
            scripts[key] = os.path.join(files, f"{prof['material']['name']}-blender.py")
        sa, ss = np.array(layer["sigma_a"]), np.array(layer["sigma_s"]) * (1 - layer["g"][0])
        sigma_tr = np.sqrt(3 * sa * (sa + ss))
        width_mm = 2.0 * HALF_WIDTH_DIFFUSION_LENGTHS / sigma_tr.min()
        cols = columns(width_mm, a.width_px)
        edges = np.array(prof["r_edges"])
        total = np.array(prof["total_rd"])
        material_edge = [pixel_edge(edges, np.array(prof["rd"][c]), total[c], cols)
                         for c in range(3)]
        cases = []
        for m in a.methods.split(","):
            if m == "burley":
                b = fits["cb"]["rendered"]
                claim = [pixel_edge(*burley_bins(b["albedo"][c], b["d_mm"][c],
                                                 b.get("truncate_d")), cols)
                         for c in range(3)]
                cases.append(("Christensen-Burley",
                              "ssskit engine --subsurface-method christensen-burley",
                              dict(script=scripts["cb"]), fits["cb"]["params"], claim, None))
            elif m == "random-walk":
                claim, claim_err = walk_claim(fits["rw"], cols)
                cases.append(("Random Walk", "ssskit engine", dict(script=scripts["rw"]),
                              fits["rw"]["params"], claim, claim_err))
            elif m == "random-walk-skin":
                # Skin reads the radius through a dipole fit of the albedo
                # (bssrdf.h `bssrdf_setup_radius`) and starts half of the
                # walks cosine-weighted, the rest through a GGX facet of
                # roughness 1 (subsurface.h `subsurface_entry_bounce`):
                # ssskit's Random Walk values rendered, unclaimed.
                extra = {"Subsurface IOR": layer["eta"]}
                cases.append(("Random Walk (Skin)", "ssskit engine, Subsurface IOR = eta",
                              dict(script=scripts["rw"], method="RANDOM_WALK_SKIN", extra=extra),
                              dict(fits["rw"]["params"], **extra), None, None))
            else:
                sys.exit(f"unknown method {m}")
        job = dict(spp=a.spp, threads=a.threads, width_px=a.width_px, height_px=a.height_px,
                   width_m=width_mm * UNITS_PER_MM, timing_out=os.path.join(tmp, "t.json"),
                   renders=[dict(material="white", seed=1, path=os.path.join(tmp, "white.exr"))])
        for i, (_, _, render, _, _, _) in enumerate(cases):
            for seed in (1, 2):
                job["renders"].append(dict(render, material="slab", seed=seed,
                                           path=os.path.join(tmp, f"{name}-{i}-{seed}.exr")))
        jpath = os.path.join(tmp, f"{name}-job.json")
        json.dump(job, open(jpath, "w"))
        cpu = children_cpu()
        subprocess.run([sys.executable, SCENE, jpath], check=True, stdout=subprocess.DEVNULL)
        render_cpu[name] = children_cpu() - cpu
        seconds = json.load(open(job["timing_out"]))["seconds"]
        white = read_rgb(job["renders"][0]["path"]).mean(axis=0)
        half = a.width_px // 2
        # The shadow's edge falls on the boundary between the two middle
        # columns: nothing left of it, E / pi right of it.
        lit = white[half:].mean(axis=0)
        if (white[:half].max() > WHITE_STEP_TOL * lit.max()
                or np.ptp(white[half:], axis=0).max() > WHITE_STEP_TOL * lit.max()):
            sys.exit("white render: the shadow edge is not a clean step at the centre")
        plateau = cols[0] >= PLATEAU * 0.5 * width_mm
        for i, (label, values_from, _, values, claim, claim_err) in enumerate(cases):
            r = [read_rgb(os.path.join(tmp, f"{name}-{i}-{s}.exr")).mean(axis=0) / lit
                 for s in (1, 2)]
            mean = 0.5 * (r[0] + r[1])
            secs = [seconds[os.path.join(tmp, f"{name}-{i}-{s}.exr")] for s in (1, 2)]
            entry = dict(method=label, values_from=values_from, values=values,
                         seconds=secs, channels={})
            for c, ch in enumerate("rgb"):
                step = total[c]
                noise = float(np.sqrt(np.mean(((r[0][:, c] - r[1][:, c]) / 2.0) ** 2))) / step
                rendered = rms(mean[:, c] - material_edge[c]) / step
                colour = float(mean[plateau, c].mean() / material_edge[c][plateau].mean() - 1.0)
                e = dict(noise=noise, rendered=rendered, rendered_beyond_noise=beyond(
                    rendered, noise), render_plateau=float(mean[-1, c]), total=float(step),
                    rendered_colour=colour)
                row = [name, label, values_from, ch, pct_signed(colour)]
                if claim is not None:
                    claimed = rms(claim[c] - material_edge[c]) / step
                    vs = rms(mean[:, c] - claim[c]) / step
                    # The claim's own Monte Carlo noise adds to the render's.
                    cn = 0.0 if claim_err is None else rms(claim_err[c]) / step
                    both = math.hypot(noise, cn)
                    e.update(claimed=claimed, render_vs_claim=vs, claim_noise=cn,
                             agrees=bool(vs <= AGREE_FACTOR * both),
                             claimed_colour=float(claim[c][plateau].mean()
                                                  / material_edge[c][plateau].mean() - 1.0))
                    row += [pct(claimed), pct(rendered), pct(both), pct(vs),
                            "yes" if vs <= AGREE_FACTOR * both else "NO"]
                else:
                    row += ["-", pct(rendered), pct(noise), "-", "-"]
                rows.append(row)
                entry["channels"][ch] = e
            data.setdefault(name, []).append(entry)
            print(" | ".join(rows[-3][:2]) + ": " + "; ".join(
                " ".join(x[3:]) for x in rows[-3:]), flush=True)
    header = ["material", "method", "values from", "channel", "rendered colour vs material %",
              "claimed edge error %",
              "rendered edge error %", "noise (render and claim) %", "render vs claim %",
              f"claim within {AGREE_FACTOR} x noise"]
    command = "scripts/engine-cycles " + " ".join(shlex.quote(x) for x in sys.argv[1:])
    record = {
        "schema": "ssskit.record/1",
        "command": command.strip(),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d"),
        "machine": machine,
        "tables": {"edge": {"header": header, "rows": rows}},
        "data": dict(materials=data, spp=a.spp, width_px=a.width_px, height_px=a.height_px,
                     seconds_total=time.time() - started,
                     cpu_seconds_total=children_cpu() - cpu_started,
                     render_cpu_seconds=render_cpu,
                     blender=json.load(open(job["timing_out"]))["blender"]),
    }
    os.makedirs(os.path.dirname(a.record), exist_ok=True)
    with open(a.record + ".tmp", "w") as f:
        f.write(json.dumps(record, indent=2) + "\n")
    os.replace(a.record + ".tmp", a.record)
    print(f"-> {os.path.relpath(a.record, ROOT)} ({time.time() - started:.0f} s wall, "
          f"{children_cpu() - cpu_started:.0f} CPU s in Blender and ssskit)")


def children_cpu():
    """CPU seconds (user + system) of the finished child processes."""
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def beyond(x, noise):
    return float(np.sqrt(max(x * x - noise * noise, 0.0)))


def pct(x):
    return f"{100.0 * x:.2f}"


def pct_signed(x):
    return f"{100.0 * x:+.2f}"


if __name__ == "__main__":
    main()
