#!/usr/bin/env python3
"""Generate ``station/data/spectral-palette.json``: K(λ), S(λ) of every palette pigment in
12 bands of 25 nm over 400–700 nm, and the band → linear sRGB matrix.

    pip install ".[tools]"   # colour-science, generation time only; the station needs NumPy
    python tools/gen_spectral_palette.py [--check]

**Colour matching.** CIE 1931 2° colour-matching functions times CIE D65, both at 1 nm
from colour-science (``colour.MSDS_CMFS``, ``colour.SDS_ILLUMINANTS``), summed over each
band give the band's XYZ weights; the IEC 61966-2-1 XYZ → linear sRGB matrix follows.
The rows are rescaled so a flat spectrum ``r`` renders as grey ``(r, r, r)``: the paper's
white is white (the truncation to 400–700 nm and the matrix's rounding otherwise tint it
by < 1 %).

**Pigments.** Each pigment's absorption K(λ) is a small physical model built from its
chemistry (Colour Index names in ``MODELS``): a flat floor plus absorption *edges*
(a semiconductor's or a yellow dye's band gap: logistic, absorbing below λ0) and
absorption *bands* (an electronic transition: Gaussian, centre and width bounded to the
pigment's known absorption maximum). Scattering S(λ) = exp(s0 + s1 x + s2 x²),
x = (λ − 550 nm) / 150 nm, smooth as particle scattering is. The parameters are fitted
(SciPy least squares, bounds = the chemistry) so that the pigment's colour at thickness
0.25 and 1 over white paper and over black matches, in CIELAB, the colour Curtis's RGB
K and S give there (Curtis et al. 1997 defined their K, S from exactly these two
appearances). The mean and largest ΔE76 of each fit go into the file.

``--check`` writes nothing and exits 1 when the file's numbers differ from a fresh fit by
more than 1e-3 relative (other SciPy builds round the last digits differently).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "station" / "data" / "spectral-palette.json"
LO, HI, NB = 400, 700, 12
EDGES = np.linspace(LO, HI, NB + 1)
CENTRES = 0.5 * (EDGES[:-1] + EDGES[1:])
THICK = (0.1, 0.25, 0.5, 1.0)
XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415],
                        [0.0557, -0.2040, 1.0570]])

# Per pigment: the K(λ) features (kind, (centre lo, hi), (width lo, hi)) in nm. "edge":
# absorbs below the centre (band gap / yellow dyes), "redge": absorbs above it, "band":
# a Gaussian absorption band. The bounds are the pigments' documented absorption.
MODELS: dict[str, tuple[str, list[tuple[str, tuple[float, float], tuple[float, float]]]]] = {
    # iron(III) oxide: charge-transfer edge in the green-yellow, broad
    "Indian Red": ("PR101", [("edge", (540, 600), (15, 45)), ("edge", (420, 480), (10, 40))]),
    # quinacridone: absorption band in the green (max ~ 540-560 nm), transmits red and violet
    "Quinacridone Rose": ("PV19", [("band", (520, 570), (20, 50)),
                                   ("edge", (400, 450), (5, 25))]),
    # cadmium sulfide: band gap 2.4 eV, edge ~ 500 nm
    "Cadmium Yellow": ("PY35", [("edge", (485, 520), (5, 15))]),
    # hooker's green: a phthalo/yellow blend; absorbs red and blue, window in the green
    "Hookers Green": ("PG7+PY", [("redge", (580, 630), (10, 35)), ("edge", (460, 500), (5, 20))]),
    # cobalt stannate: absorbs orange-red, transmits blue-green
    "Cerulean Blue": ("PB35", [("redge", (560, 620), (10, 40)), ("edge", (400, 440), (5, 25))]),
    # hydrated iron oxide + manganese: absorption rising smoothly towards the blue
    "Burnt Umber": ("PBr7", [("edge", (520, 640), (30, 90))]),
    # cadmium sulfoselenide: edge ~ 590 nm
    "Cadmium Red": ("PR108", [("edge", (570, 610), (5, 15)), ("band", (400, 560), (30, 120))]),
    # an orange (perinone/azo type): edge ~ 550-570 nm
    "Brilliant Orange": ("PO43", [("edge", (530, 580), (5, 40)), ("edge", (420, 500), (5, 40))]),
    # arylide yellow: a sharp edge near 480-500 nm
    "Hansa Yellow": ("PY3", [("edge", (470, 495), (4, 10))]),
    # chlorinated copper phthalocyanine: Q band in the red (max ~ 640-660 nm), Soret edge
    # in the violet
    "Phthalo Green": ("PG7", [("band", (620, 680), (25, 60)), ("edge", (420, 470), (5, 20))]),
    # sodium aluminosilicate with S3- radicals: one broad band centred near 600 nm that
    # takes the yellow-green as well as the orange (FWHM ~ 140-200 nm), a window at
    # 400-480 nm and the red tail above ~ 680 nm that makes the pigment violet-leaning
    "French Ultramarine": ("PB29", [("band", (580, 615), (55, 100))]),
    # interference (TiO2-coated mica): little absorption, scattering colours the paint
    "Interference Lilac": ("mica/TiO2", []),
    "Black": ("fictional", []),
    # titanium dioxide: band gap 3.0 eV, edge below 410 nm
    "Titanium White": ("PW6", [("edge", (395, 420), (5, 12))]),
    # carbon black: flat
    "Sumi Ink": ("PBk6", []),
    # burnt umber with carbon black: the umber's edge over a flat black floor
    "Sepia": ("PBr7+PBk6", [("edge", (520, 640), (30, 90))]),
}


def _read_csv(path: Path) -> list[dict[str, str]]:
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines()
             if ln.strip() and not ln.lstrip().startswith("#")]
    return list(csv.DictReader(io.StringIO("\n".join(lines))))


def curtis_table() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Name → (K, S) per RGB of every pigment of the station's palette files."""
    data = ROOT / "station" / "data"
    out = {}
    for r in _read_csv(data / "palette-curtis.csv"):
        out[r["name"]] = (np.array([float(r[f"K_{c}"]) for c in "rgb"]),
                          np.array([float(r[f"S_{c}"]) for c in "rgb"]))
    for r in _read_csv(data / "pigment-properties.csv"):
        if r["K_r"]:
            out[r["name"]] = (np.array([float(r[f"K_{c}"]) for c in "rgb"]),
                              np.array([float(r[f"S_{c}"]) for c in "rgb"]))
    return out


def band_matrix() -> np.ndarray:
    """(3, NB): band reflectance → linear sRGB, each row summing to 1."""
    import colour  # generation time only

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    lam = np.arange(LO, HI)
    w = 0.5 * (cmfs[lam] + cmfs[lam + 1])  # trapezoid per nm
    e = 0.5 * (d65[lam] + d65[lam + 1])
    xyz = np.zeros((NB, 3))
    for b in range(NB):
        sel = (lam >= EDGES[b]) & (lam < EDGES[b + 1])
        xyz[b] = (w[sel] * e[sel, None]).sum(axis=0)
    m = XYZ_TO_SRGB @ xyz.T  # (3, NB)
    return m / m.sum(axis=1, keepdims=True)


def km(k: np.ndarray, s: np.ndarray, d: float, r_prev: float) -> np.ndarray:
    """KM reflectance of a layer (thickness d) over r_prev, float64 (same as render.py)."""
    s = np.maximum(s, 1e-12)
    a = (s + k) / s
    b = np.sqrt(np.maximum(a * a - 1, 0))
    t = np.minimum(b * s * d, 30)
    small = b < 1e-4
    den = np.where(small, 1.0, a * np.sinh(t) + b * np.cosh(t))
    r = np.where(small, s * d / (1 + s * d), np.sinh(t) / den)
    tr = np.where(small, 1 / (1 + s * d), b / den)
    return r + tr * tr * r_prev / (1 - r * r_prev)


def lab(rgb: np.ndarray) -> np.ndarray:
    m = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                  [0.0193, 0.1192, 0.9505]])
    xyz = np.clip(rgb, 0, None) @ m.T / m.sum(axis=1)
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]),
                     200 * (f[..., 1] - f[..., 2])], axis=-1)


def _shape(kind: str, c: float, w: float) -> np.ndarray:
    x = (CENTRES - c) / w
    if kind == "band":
        return np.exp(-0.5 * x * x)
    if kind == "edge":
        return 1.0 / (1.0 + np.exp(np.clip(x, -50, 50)))
    return 1.0 / (1.0 + np.exp(np.clip(-x, -50, 50)))  # redge


class Model:
    """Parameters: log floor, then per feature (log amplitude, centre, width), then s0..s2."""

    def __init__(self, feats: list[tuple[str, tuple[float, float], tuple[float, float]]],
                 slope: float = 6.0):
        self.feats = feats
        self.slope = slope  # bound on the scattering's spectral slope and curvature

    def bounds(self) -> tuple[list[float], list[float]]:
        lo, hi = [-9.0], [2.0]
        for _, c, w in self.feats:
            lo += [-6.0, c[0], w[0]]
            hi += [3.0, c[1], w[1]]
        return [*lo, -12.0, -self.slope, -self.slope], [*hi, 3.0, self.slope, self.slope]

    def start(self, kk: np.ndarray, ss: np.ndarray) -> np.ndarray:
        x = [float(np.log(max(kk.min(), 1e-4)))]
        for _, c, w in self.feats:
            x += [float(np.log(max(kk.max(), 1e-3))), 0.5 * sum(c), 0.5 * sum(w)]
        return np.array([*x, float(np.log(ss.mean())), 0.0, 0.0])

    def spectra(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = np.full(NB, np.exp(x[0]))
        for i, (kind, _, _) in enumerate(self.feats):
            a, c, w = x[1 + 3 * i: 4 + 3 * i]
            k = k + np.exp(a) * _shape(kind, c, w)
        u = (CENTRES - 550.0) / 150.0
        s0, s1, s2 = x[-3:]
        return k, np.exp(s0 + s1 * u + s2 * u * u)


def appearances(k: np.ndarray, s: np.ndarray, m: np.ndarray | None) -> np.ndarray:
    """Lab at each thickness over white and over black; ``m`` None: k, s are RGB."""
    out = []
    for d in THICK:
        for under in (1.0, 0.0):
            r = km(k, s, d, under)
            out.append(lab(r if m is None else m @ r))
    return np.array(out)


# Pigments whose Curtis RGB K, S paint the wrong hue: the fit keeps Curtis's lightness and
# chroma but aims at the real pigment's masstone hue (HSV of the displayed sRGB, degrees).
# French Ultramarine PB29: Curtis's K_r = K_g makes it azure (HSV ~ 214); the pigment is a
# violet-leaning deep blue, HSV ~ 240-250 with CIELAB a* > 0 (issue 21 item 6; the S3-
# chromophore's band near 600 nm, see docs/canvas-model.md for the sources). Quinacridone
# Rose PV19 (a cool rose, HSV ~ 336; Curtis's K, S: 320, magenta) and Cerulean Blue PB35 (a
# sky blue, HSV ~ 196; Curtis's: 185, turquoise): approximate painted-swatch hues.
HUE_TARGETS: dict[str, float] = {"French Ultramarine": 245.0, "Quinacridone Rose": 336.0,
                                 "Cerulean Blue": 196.0}


def _hsv_hue(rgb: np.ndarray) -> float:
    x = np.clip(rgb, 0, 1)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    r, g, b = srgb
    mx, mn = max(r, g, b), min(r, g, b)
    if mx - mn < 1e-9:
        return 0.0
    if mx == b:
        h = 4.0 + (r - g) / (mx - mn)
    elif mx == g:
        h = 2.0 + (b - r) / (mx - mn)
    else:
        h = (g - b) / (mx - mn)
    return float((60.0 * h) % 360.0)


def fit(name: str, kk: np.ndarray, ss: np.ndarray, m: np.ndarray) -> dict[str, object]:
    ci, feats = MODELS[name]
    hue = HUE_TARGETS.get(name)
    # a hue-targeted fit may not buy its hue with scattering that rises tenfold across the
    # spectrum (it would tint the paint over dark): particle scattering stays smooth
    model = Model(feats, 6.0 if hue is None else 1.0)
    want = appearances(kk, ss, None)

    def resid(x: np.ndarray) -> np.ndarray:
        k, s = model.spectra(x)
        if hue is None:
            return (appearances(k, s, m) - want).ravel()
        got = appearances(k, s, m)
        chroma = np.hypot(got[:, 1], got[:, 2]) - np.hypot(want[:, 1], want[:, 2])
        hues = [_hsv_hue(m @ km(k, s, d, 1.0)) - hue for d in THICK[1:]]
        return np.concatenate([got[:, 0] - want[:, 0], chroma, 2.0 * np.array(hues)])

    lo, hi = model.bounds()
    best = None
    rng = np.random.default_rng(0)
    for trial in range(4):
        x0 = np.clip(model.start(kk, ss) if trial == 0 else rng.uniform(lo, hi), lo, hi)
        res = least_squares(resid, x0, bounds=(lo, hi), method="trf", max_nfev=4000)
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    k, s = model.spectra(best.x)
    de = np.linalg.norm((appearances(k, s, m) - want), axis=1)
    return {"name": name, "colour_index": ci,
            "K": [float(f"{v:.6g}") for v in k], "S": [float(f"{v:.6g}") for v in s],
            "features": [{"kind": f[0], "amplitude": round(float(np.exp(best.x[1 + 3 * i])), 4),
                          "centre_nm": round(float(best.x[2 + 3 * i]), 1),
                          "width_nm": round(float(best.x[3 + 3 * i]), 1)}
                         for i, f in enumerate(feats)],
            "fit_dE76_mean": round(float(de.mean()), 3), "fit_dE76_max": round(float(de.max()), 3)}


def generate() -> dict[str, object]:
    m = band_matrix()
    table = curtis_table()
    missing = sorted(set(table) - set(MODELS))
    if missing:
        raise SystemExit(f"no spectral model for {', '.join(missing)}")
    return {
        "format": "station-spectral-palette", "version": 1,
        "provenance": ("tools/gen_spectral_palette.py: CIE 1931 2° CMFs x D65 at 1 nm "
                       "(colour-science), per-pigment absorption models fitted to the RGB "
                       "appearance of the Curtis 1997 K, S at thickness 0.25 and 1 over "
                       "white and black; see docs/canvas-model.md"),
        "band_edges_nm": [float(v) for v in EDGES],
        "band_to_linear_srgb": [[round(float(v), 7) for v in row] for row in m],
        "pigments": [fit(n, *table[n], m) for n in table],
    }


def _close(a: object, b: object) -> bool:
    """Same structure, numbers within 1e-3 relative (1e-6 absolute)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return bool(np.isclose(a, b, rtol=1e-3, atol=1e-6))
    return a == b


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if the file would change")
    args = ap.parse_args()
    text = json.dumps(generate(), indent=1) + "\n"
    if args.check:
        same = OUT.exists() and _close(json.loads(OUT.read_text(encoding="utf-8")),
                                       json.loads(text))
        print("up to date" if same else f"{OUT} differs")
        return 0 if same else 1
    OUT.write_text(text, encoding="utf-8")
    data = json.loads(text)
    for p in data["pigments"]:
        print(f"{p['name']:20s} dE mean {p['fit_dE76_mean']:6.2f} max {p['fit_dE76_max']:6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
