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
  from their difference; "beyond noise" is sqrt(RMS^2 - noise^2).

A claim agrees with the render when the render's RMS against it is within
AGREE_FACTOR times the noise (the RMS of pure noise over N columns
scatters by about sqrt(1 / (2 N)) of itself: 5% at 200 columns; the
factor leaves room for the noise estimate from only two renders).
"""

import argparse
import datetime
import json
import math
import os
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


# ------------------------------------------------------------ Cycles chain


def chiang_alpha(albedo, g):
    """Cycles' `subsurface_random_walk_remap` (kernel/integrator/
    subsurface_random_walk.h, v5.0.0): single-scattering albedo from the
    surface albedo (Chiang et al. 2016, as Cycles refits it for
    anisotropy)."""
    g2, g3, g4, g5, g6, g7 = g ** 2, g ** 3, g ** 4, g ** 5, g ** 6, g ** 7
    A = (1.8260523782 - 1.28451056436 * g - 1.79904629312 * g2 + 9.19393289202 * g3
         - 22.8215585862 * g4 + 32.0234874259 * g5 - 23.6264803333 * g6 + 7.21067002658 * g7)
    B = 4.98511194385 + 0.127355959438 * math.exp(
        31.1491581433 * g - 201.847017512 * g2 + 841.576016723 * g3 - 2018.09288505 * g4
        + 2731.71560286 * g5 - 1935.41424244 * g6 + 559.009054474 * g7)
    C = (1.09686102424 - 0.394704063468 * g + 1.05258115941 * g2 - 8.83963712726 * g3
         + 28.8643230661 * g4 - 46.8802913581 * g5 + 38.5402837518 * g6 - 12.7181042538 * g7)
    D = (0.496310210422 + 0.360146581622 * g - 2.15139309747 * g2 + 17.8896899217 * g3
         - 55.2984010333 * g4 + 82.065982243 * g5 - 58.5106008578 * g6 + 15.8478295021 * g7)
    E = 4.23190299701 + 0.00310603949088 * math.exp(
        76.7316253952 * g - 594.356773233 * g2 + 2448.8834203 * g3 - 5576.68528998 * g4
        + 7116.60171912 * g5 - 4763.54467887 * g6 + 1303.5318055 * g7)
    F = (2.40602999408 - 2.51814844609 * g + 9.18494908356 * g2 - 79.2191708682 * g3
         + 259.082868209 * g4 - 403.613804597 * g5 + 302.85712436 * g6 - 87.4370473567 * g7)
    blend = albedo ** 0.25
    alpha = ((1.0 - blend) * A * math.atan(B * albedo) ** C
             + blend * D * math.atan(E * albedo) ** F)
    return min(max(alpha, 0.0), 0.999999)


# `subsurface_random_walk_coefficients`: alpha below this is raised to it
# and the throughput scaled by alpha / MIN_ALPHA.
MIN_ALPHA = 0.2


def random_walk_medium(values, g):
    """The medium Cycles' Random Walk walks in, from the node's values
    (kernel/svm/closure.h, principled: radius = Subsurface Radius x Scale,
    albedo = min(Base Color, 1); bssrdf.h `bssrdf_setup_radius`: radius x
    1 / (4 pi) for CLOSURE_BSSRDF_RANDOM_WALK_ID; subsurface_random_walk.h:
    sigma_t = 1 / (radius (1 - g)), sigma_s = alpha sigma_t). Returns
    per-mm sigma_a, sigma_s and the throughput factor of the MIN_ALPHA
    clamp."""
    sa, ss, scale = [], [], []
    for c in range(3):
        albedo = min(max(values["Base Color"][c], 0.0), 1.0)
        radius_mm = values["Subsurface Radius"][c] * values["Subsurface Scale"] / UNITS_PER_MM
        d = radius_mm * 0.25 / math.pi
        sigma_t = 1.0 / (d * (1.0 - g))
        alpha = chiang_alpha(albedo, g)
        k = 1.0
        if alpha < MIN_ALPHA:
            k, alpha = alpha / MIN_ALPHA, MIN_ALPHA
        sa.append(sigma_t * (1.0 - alpha))
        ss.append(sigma_t * alpha)
        scale.append(k)
    return sa, ss, scale


def random_walk_export(layer):
    """The Random Walk values whose medium (random_walk_medium) is the
    material's: d = 1 / (sigma_t (1 - g)), alpha = sigma_s / sigma_t, the
    Base Color the albedo that Cycles' remap sends to alpha (bisection:
    the remap rises with the albedo)."""
    g = layer["g"][0]
    colour, radius = [], []
    for c in range(3):
        st = layer["sigma_a"][c] + layer["sigma_s"][c]
        alpha = layer["sigma_s"][c] / st
        lo, hi = 0.0, 1.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if chiang_alpha(mid, g) < alpha:
                lo = mid
            else:
                hi = mid
        colour.append(float(f"{0.5 * (lo + hi):.4g}"))
        radius.append(4.0 * math.pi / (st * (1.0 - g)) * UNITS_PER_MM)
    scale = max(radius)
    return {
        "Base Color": colour,
        "Subsurface Radius": [float(f"{r / scale:.4g}") for r in radius],
        "Subsurface Scale": float(f"{scale:.4g}"),
        "Subsurface Anisotropy": g,
        "IOR": layer["eta"],
    }


def random_walk_fit(a, prof, name, tmp, cols, material_edge):
    """Random Walk values fitted to the material's edge response: Base
    Color = the material's total reflectance (capped at 1; the remap of
    Chiang et al. 2016 is fitted so that the walk's multiple-scattering
    albedo is the Base Color), and per channel the scale of the walk fitted by least
    squares on the edge response. An index-matched half-space's profile
    scales with the extinction, R(r; s sigma_t) = s^2 R(s r; sigma_t) (all
    lengths in units of 1 / sigma_t), so one Monte Carlo run at sigma_t =
    1 / mm per channel gives every scale."""
    g = prof["material"]["layers"][0]["g"][0]
    colour = [float(f"{min(t, 1.0):.4g}") for t in prof["total_rd"]]
    alpha = [chiang_alpha(c, g) for c in colour]
    k = [1.0 if x >= MIN_ALPHA else x / MIN_ALPHA for x in alpha]
    alpha = [max(x, MIN_ALPHA) for x in alpha]
    unit = simulate_medium(a.bin, name + "-unit", [1.0 - x for x in alpha], alpha, g,
                           a.photons, tmp)
    edges = np.array(unit["r_edges"])
    radius = []
    for c in range(3):
        rd = k[c] * np.array(unit["rd"][c])
        tot = k[c] * unit["total_rd"][c]

        def cost(log_s):
            s = math.exp(log_s)
            return rms(pixel_edge(edges / s, rd * s * s, tot, cols) - material_edge[c])

        lo, hi = math.log(0.05), math.log(20.0)
        grid = np.linspace(lo, hi, 25)
        i = int(np.argmin([cost(x) for x in grid]))
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        for _ in range(30):  # golden section
            m1, m2 = hi - 0.618 * (hi - lo), lo + 0.618 * (hi - lo)
            if cost(m1) < cost(m2):
                hi = m2
            else:
                lo = m1
        s = math.exp(0.5 * (lo + hi))  # sigma_t in 1 / mm
        radius.append(4.0 * math.pi / (s * (1.0 - g)) * UNITS_PER_MM)
    scale = max(radius)
    return {
        "Base Color": colour,
        "Subsurface Radius": [float(f"{r / scale:.4g}") for r in radius],
        "Subsurface Scale": float(f"{scale:.4g}"),
        "Subsurface Anisotropy": g,
        "IOR": prof["material"]["layers"][0]["eta"],
        "Subsurface Weight": 1.0,
    }


# ---------------------------------------------------------------- running


def ssskit(args, binary):
    subprocess.run([binary] + args, check=True, stdout=subprocess.DEVNULL)


def simulate_medium(binary, name, sa, ss, g, photons, tmp):
    """ssskit's Monte Carlo profile of a half-space with the given
    coefficients and an index-matched boundary (eta = 1): Cycles' walk
    leaves at the first surface crossing (subsurface_random_walk.h) and
    enters at normal incidence straight down for a sun at the zenith."""
    toml = os.path.join(tmp, f"{name}-rw.toml")
    with open(toml, "w") as f:
        f.write(f'name = "{name}-cycles-rw"\nunit = "mm"\n'
                f"sigma_a = {list(sa)}\nsigma_s = {list(ss)}\ng = {g}\neta = 1.0\n")
    out = os.path.join(tmp, f"{name}-rw.json")
    ssskit(["simulate", "--material", toml, "--photons", str(photons), "--threads", "2",
            "--out", out], binary)
    return json.load(open(out))


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
    ap.add_argument("--methods",
                    default="burley,random-walk,random-walk-skin,random-walk-export,random-walk-fit")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--width-px", type=int, default=200)
    ap.add_argument("--height-px", type=int, default=40)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--photons", type=int, default=300000,
                    help="photons per channel of the Random Walk claim's Monte Carlo")
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "ssskit"))
    ap.add_argument("--record", default=os.path.join(ROOT, "docs", "records",
                                                     "engine-cycles.json"))
    ap.add_argument("--keep", help="keep the renders in this folder")
    a = ap.parse_args()
    machine = machine_line()
    tmp = a.keep or tempfile.mkdtemp(prefix="engine-cycles-")
    os.makedirs(tmp, exist_ok=True)
    rows, data = [], {}
    started = time.time()
    for name in a.materials.split(","):
        prof_path = os.path.join(ROOT, "profiles", "reference", f"{name}.json")
        prof = json.load(open(prof_path))
        layer = prof["material"]["layers"][0]
        if len(prof["material"]["layers"]) != 1 or len(set(layer["g"])) != 1:
            sys.exit(f"{name}: one layer with one g is what Cycles' walk takes")
        out = os.path.join(tmp, f"{name}-blender.json")
        files = os.path.join(tmp, f"{name}-blender-files")
        ssskit(["engine", "--profile", prof_path, "--engine", "blender", "--out", out,
                "--out-dir", files], a.bin)
        fit = json.load(open(out))
        printed = {k: fit["params"][k] for k in
                   ["Base Color", "Subsurface Radius", "Subsurface Scale", "Subsurface Weight"]}
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
                b = fit["rendered"]
                claim = [pixel_edge(*burley_bins(b["albedo"][c], b["d_mm"][c],
                                                 b.get("truncate_d")), cols)
                         for c in range(3)]
                cases.append(("Christensen-Burley", "ssskit engine (default)", "BURLEY",
                              dict(printed, IOR=layer["eta"]), claim))
            elif m == "random-walk":
                # ssskit's printed values under Random Walk: what a user who
                # keeps Blender's default method gets.
                v = dict(printed, IOR=layer["eta"])
                cases.append(("Random Walk", "ssskit engine (Burley values)", "RANDOM_WALK",
                              v, rw_claim(a, v, layer, name + "-burleyvals", tmp, cols)))
            elif m == "random-walk-export":
                v = random_walk_export(layer)
                v["Subsurface Weight"] = 1.0
                cases.append(("Random Walk", "coefficients (item 2 export)", "RANDOM_WALK",
                              v, rw_claim(a, v, layer, name + "-coef", tmp, cols)))
            elif m == "random-walk-fit":
                v = random_walk_fit(a, prof, name, tmp, cols, material_edge)
                cases.append(("Random Walk", "fitted to the edge (script)", "RANDOM_WALK",
                              v, rw_claim(a, v, layer, name + "-fit", tmp, cols)))
            elif m == "random-walk-skin":
                # Skin reads the radius through a dipole fit of the albedo
                # and enters half the paths diffusely (bssrdf.h,
                # subsurface.h): rendered with ssskit's values, unclaimed.
                v = dict(printed, IOR=layer["eta"], **{"Subsurface IOR": layer["eta"]})
                cases.append(("Random Walk (Skin)", "ssskit engine (Burley values)",
                              "RANDOM_WALK_SKIN", v, None))
            else:
                sys.exit(f"unknown method {m}")
        job = dict(spp=a.spp, threads=a.threads, width_px=a.width_px, height_px=a.height_px,
                   width_m=width_mm * UNITS_PER_MM, timing_out=os.path.join(tmp, "t.json"),
                   material_script=os.path.join(files, f"{prof['material']['name']}-blender.py"),
                   renders=[dict(material="white", seed=1, path=os.path.join(tmp, "white.exr"))])
        for i, (_, _, method, values, _) in enumerate(cases):
            for seed in (1, 2):
                job["renders"].append(dict(material="slab", method=method, values=values,
                                           seed=seed,
                                           path=os.path.join(tmp, f"{name}-{i}-{seed}.exr")))
        jpath = os.path.join(tmp, f"{name}-job.json")
        json.dump(job, open(jpath, "w"))
        subprocess.run([sys.executable, SCENE, jpath], check=True, stdout=subprocess.DEVNULL)
        seconds = json.load(open(job["timing_out"]))["seconds"]
        white = read_rgb(job["renders"][0]["path"]).mean(axis=0)
        half = a.width_px // 2
        # The shadow's edge falls on the boundary between the two middle
        # columns: nothing left of it, E / pi right of it.
        lit = white[half:].mean(axis=0)
        if (white[:half].max() > WHITE_STEP_TOL * lit.max()
                or np.ptp(white[half:], axis=0).max() > WHITE_STEP_TOL * lit.max()):
            sys.exit("white render: the shadow edge is not a clean step at the centre")
        for i, (label, values_from, method, values, claim) in enumerate(cases):
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
                e = dict(noise=noise, rendered=rendered, rendered_beyond_noise=beyond(
                    rendered, noise), render_plateau=float(mean[-1, c]), total=float(step))
                row = [name, label, values_from, ch]
                if claim is not None:
                    claimed = rms(claim[c] - material_edge[c]) / step
                    vs = rms(mean[:, c] - claim[c]) / step
                    e.update(claimed=claimed, render_vs_claim=vs,
                             agrees=bool(vs <= AGREE_FACTOR * noise))
                    row += [pct(claimed), pct(rendered), pct(noise), pct(vs),
                            "yes" if vs <= AGREE_FACTOR * noise else "NO"]
                else:
                    row += ["-", pct(rendered), pct(noise), "-", "-"]
                rows.append(row)
                entry["channels"][ch] = e
            data.setdefault(name, []).append(entry)
            print(" | ".join(rows[-3][:2]) + ": " + "; ".join(
                " ".join(x[3:]) for x in rows[-3:]), flush=True)
    header = ["material", "method", "values from", "channel", "claimed edge error %",
              "rendered edge error %", "render noise %", "render vs claim %",
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
                     blender=json.load(open(job["timing_out"]))["blender"]),
    }
    os.makedirs(os.path.dirname(a.record), exist_ok=True)
    with open(a.record + ".tmp", "w") as f:
        f.write(json.dumps(record, indent=2) + "\n")
    os.replace(a.record + ".tmp", a.record)
    print(f"-> {os.path.relpath(a.record, ROOT)} ({time.time() - started:.0f} s)")


def rw_claim(a, values, layer, name, tmp, cols):
    sa, ss, k = random_walk_medium(values, layer["g"][0])
    p = simulate_medium(a.bin, name, sa, ss, layer["g"][0], a.photons, tmp)
    edges = np.array(p["r_edges"])
    return [pixel_edge(edges, k[c] * np.array(p["rd"][c]), k[c] * p["total_rd"][c], cols)
            for c in range(3)]


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def beyond(x, noise):
    return float(np.sqrt(max(x * x - noise * noise, 0.0)))


def pct(x):
    return f"{100.0 * x:.2f}"


if __name__ == "__main__":
    main()
