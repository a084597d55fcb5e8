#!/usr/bin/python3
"""Render the independent validation set (gestures, tracking, slides) from real hand silhouettes.

This renderer shares no code and no model with include/shadowsense/sim on purpose (see
docs/validation_set.md for the list of differences): stereographic lens with an off-centre
principal point, knit (twill) fabric with quilted diamond seams, several lights with coloured
ambient, an exponential hover fade, signal-dependent (shot + read + row banding) noise and a JPEG
round trip. Bodies are built from the real hand silhouettes in data/realhand (manifest.csv) plus
forearms, a torso and arms of our own.

Output layout and csv columns are those of docs/dataset_format.md, so <shadowsense/io/dataset.hpp>
(ss_eval_classify, ss_track_eval) reads it. Deterministic: the same --seed, silhouettes and
OpenCV/numpy build give the same files, for any --workers.

Usage:
  /usr/bin/python3 tools/realhand/render.py --out DIR [--seed N] [--users 5]
      [--frames-per-user 4] [--tracking-contact 60] [--tracking-empty 120]
      [--tracking-hover 120] [--slides 40] [--hands data/realhand] [--split NAME]
      [--scale S] [--hover-range LO,HI] [--only WHAT] [--workers N]
  --hands (alias --silhouettes): any folder of 1-bit silhouettes with a manifest.csv
  (tools/handsets writes them); --split keeps the rows of one split (e.g. heldout); --scale
  makes every body S times larger on the same rig (a robot whose camera sits closer).
  WHAT: gestures, tracking or slides (default: all three), or empty_skin: three frames of each
  gesture session's empty skin in gestures/empty_skin/ (for calibrated input encodings; the
  gesture frames do not change).
Exit 0 on success; 2 on bad arguments or unreadable silhouettes (message on stderr).
This is a VALIDATION set: never train or tune on it.
"""
import argparse
import csv
import math
import os
import sys

import numpy as np

try:
    import cv2
except ImportError:  # pragma: no cover
    sys.stderr.write("render.py: needs python3-opencv (tools/install-debian-deps.sh --python)\n")
    sys.exit(2)

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

GESTURES = ["nothing", "hug", "palm", "point", "punch", "two_hands"]
TRACK = ["nothing", "hover", "palm", "fist", "finger"]
DIRECTIONS = {"left": (-1.0, 0.0), "right": (1.0, 0.0), "front": (0.0, -1.0), "back": (0.0, 1.0)}
LEVEL = {"daylight": 1.0, "dusk": 0.5, "night": 0.0}

HEADER = ("file_name,class,user,lighting,lighting_level,session,frame_index,timestamp_ms,"
          "shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h,"
          "contact_cx,contact_cy,px_per_cm")


class Fail(Exception):
    pass


# --------------------------------------------------------------------------------------------
# Lens: stereographic r = 2 f tan(theta / 2), principal point off centre, skin plane at depth D.

class Rig:
    def __init__(self, w, h, depth_cm, f_px, cx_off, cy_off, kind):
        self.w, self.h, self.depth, self.f, self.kind = w, h, depth_cm, f_px, kind
        cx, cy = (w - 1) / 2 + cx_off, (h - 1) / 2 + cy_off
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        du, dv = u - cx, v - cy
        r = np.hypot(du, dv)
        theta = 2 * np.arctan(r / (2 * f_px))
        rho = depth_cm * np.tan(np.minimum(theta, np.radians(80)))
        s = np.where(r > 1e-9, rho / np.maximum(r, 1e-9), depth_cm / f_px)
        self.X = (du * s).astype(np.float32)  # skin-plane cm, x right
        self.Y = (dv * s).astype(np.float32)  # y down (image axes)
        self.px_per_cm = f_px / depth_cm
        self.vignette = (np.cos(theta) ** 2.2).astype(np.float32)
        if kind == "robot":  # superellipse window (not an ellipse)
            a, b = 0.47 * w, 0.46 * h
            vis = (np.abs(du / a) ** 4 + np.abs(dv / b) ** 4) <= 1.0
        else:  # the frame is a crop inside the 26 x 26.6 cm box top: all of it is skin
            vis = np.ones((h, w), bool)
        self.visible = vis
        # half-resolution plane coordinates for soft shapes (arms, torso), upsampled after
        self.Xh = cv2.resize(self.X, ((w + 1) // 2, (h + 1) // 2), interpolation=cv2.INTER_AREA)
        self.Yh = cv2.resize(self.Y, ((w + 1) // 2, (h + 1) // 2), interpolation=cv2.INTER_AREA)
        self.vis_f = cv2.GaussianBlur(vis.astype(np.float32), (0, 0), 1.2)


ROBOT = dict(w=635, h=350, depth_cm=32.0, f_px=7.3 * 32.0, cx_off=4.0, cy_off=-3.0, kind="robot")
BOX = dict(w=200, h=205, depth_cm=45.0, f_px=7.7 * 45.0, cx_off=2.5, cy_off=-1.5, kind="box")


# --------------------------------------------------------------------------------------------
# Silhouettes and parts. A part is a coverage function of skin-plane (X, Y) and a height (cm).

def load_silhouettes(folder, split=None):
    """Silhouettes by pose from folder/manifest.csv (columns file, pose; optional split).
    split: keep only rows whose `split` column equals it. A pose may be absent (a source without
    pointing hands, say): the classes that need it are then not rendered."""
    path = os.path.join(folder, "manifest.csv")
    try:
        rows = list(csv.DictReader(open(path)))
    except OSError as e:
        raise Fail(f"cannot read '{path}': {e}")
    if split is not None:
        if rows and "split" not in rows[0]:
            raise Fail(f"{path}: --split given but the manifest has no 'split' column")
        rows = [r for r in rows if r["split"] == split]
    out = {"palm": [], "point": [], "punch": []}
    for r in rows:
        m = cv2.imread(os.path.join(folder, r["file"]), cv2.IMREAD_GRAYSCALE)
        if m is None or r["pose"] not in out:
            raise Fail(f"{path}: cannot read silhouette '{r['file']}' (pose '{r['pose']}')")
        m = (m > 127).astype(np.float32)
        ys, xs = np.nonzero(m[-1:, :])
        wrist_x = float(xs.mean()) if len(xs) else m.shape[1] / 2
        out[r["pose"]].append({"mask": m, "wrist_x": wrist_x, "file": r["file"]})
    for k, v in out.items():
        if 0 < len(v) < 4:
            raise Fail(f"{path}: only {len(v)} silhouettes of pose '{k}'; expected 0 or >= 4")
    out = {k: v for k, v in out.items() if v}
    if "palm" not in out:
        raise Fail(f"{path}: no silhouettes of pose 'palm'{' in split ' + split if split else ''}"
                   "; hug, two_hands and palm need them")
    return out


# Pose each class needs (None: no hand). Classes whose pose a source lacks are skipped.
NEEDS = {"nothing": None, "hug": "palm", "palm": "palm", "point": "point", "punch": "punch",
         "two_hands": "palm", "fist": "punch", "finger": "point", "hover": "palm"}

# Body size multiplier (--scale): hands, forearms, torso and the spacing of two hands are this
# many times larger on the same rig, as if the camera sat closer to a proportionally larger
# skin. Heights above the skin (hover) are not scaled. Set once in main() before any worker.
SCALE = 1.0
HOVER_CM = (2.5, 15.0)  # height range of hovering hands in tracking frames (--hover-range)


POSE_LEN_CM = {"palm": 18.5, "point": 15.0, "punch": 10.5}  # silhouette height for a 1.0 user


def sil_coverage(rig, sil, pose, scale, wrist_xy, angle_deg, mirror, shift=(0.0, 0.0)):
    """Coverage [0,1] of a silhouette whose wrist point sits at wrist_xy (cm), fingers pointing
    along angle_deg (0 = -y / away from the person, image up), in image pixels."""
    m = sil["mask"]
    hpx = m.shape[0]
    cm_per_px = POSE_LEN_CM[pose] * scale / hpx
    a = math.radians(angle_deg)
    # local silhouette frame: column c (right), row r (down, wrist at bottom row)
    X = rig.X - wrist_xy[0] - shift[0]
    Y = rig.Y - wrist_xy[1] - shift[1]
    # rotate plane into the silhouette frame (fingers up = -Y when angle 0)
    ca, sa = math.cos(a), math.sin(a)
    xl = ca * X + sa * Y
    yl = -sa * X + ca * Y
    if mirror:
        xl = -xl
    col = xl / cm_per_px + sil["wrist_x"]
    row = yl / cm_per_px + (hpx - 0.5)
    return cv2.remap(m, col.astype(np.float32), row.astype(np.float32), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def capsule(rig, p0, p1, width, shift=(0.0, 0.0)):
    X = rig.Xh - shift[0]
    Y = rig.Yh - shift[1]
    px, py = p1[0] - p0[0], p1[1] - p0[1]
    L2 = px * px + py * py + 1e-9
    t = np.clip(((X - p0[0]) * px + (Y - p0[1]) * py) / L2, 0, 1)
    d = np.hypot(X - p0[0] - t * px, Y - p0[1] - t * py)
    c = np.clip((width / 2 - d) * (rig.px_per_cm / 2) + 0.5, 0, 1).astype(np.float32)
    return cv2.resize(c, (rig.w, rig.h), interpolation=cv2.INTER_LINEAR)


def ellipse(rig, c, ax, ay, shift=(0.0, 0.0)):
    X = (rig.X - shift[0] - c[0]) / ax
    Y = (rig.Y - shift[1] - c[1]) / ay
    d = (1 - np.sqrt(X * X + Y * Y)) * min(ax, ay)
    return np.clip(d * rig.px_per_cm + 0.5, 0, 1).astype(np.float32)


class Part:
    """cover(shift) -> coverage image for the part moved by shift (cm); height in cm."""

    def __init__(self, cover, height, contact=False):
        self.cover, self.height, self.contact = cover, height, contact


def arm_parts(rig, wrist, direction_deg, width, wrist_h, elev_deg, length=30.0, pieces=6):
    """Forearm from the wrist backwards (towards the person), rising at elev_deg."""
    a = math.radians(direction_deg)
    back = (-math.sin(a), math.cos(a))  # opposite of the finger direction
    parts = []
    seg = length / pieces
    for k in range(pieces):
        p0 = (wrist[0] + back[0] * seg * k, wrist[1] + back[1] * seg * k)
        p1 = (wrist[0] + back[0] * seg * (k + 1.05), wrist[1] + back[1] * seg * (k + 1.05))
        h = wrist_h + (k + 0.5) * seg * math.tan(math.radians(elev_deg))
        w = width * (1 + 0.04 * k)
        parts.append(Part(lambda s, p0=p0, p1=p1, w=w: capsule(rig, p0, p1, w, s), h))
    return parts


# --------------------------------------------------------------------------------------------
# Light, fabric, noise.

def light_preset(name, level, rng):
    """Several point lights + coloured ambient. Returns dict."""
    jit = lambda s: 1 + rng.uniform(-s, s)
    az0 = rng.uniform(0, 360)
    if name == "daylight" or (name == "custom" and level >= 0.75):
        lights = [(20, az0, 0.5), (34, az0 + 25, 0.3), (27, az0 - 30, 0.2)]
        direct = np.array([0.97, 1.0, 1.04]) * 200 * jit(0.12)
        ambient = np.array([0.80, 0.92, 1.10]) * 0.36
        gain, read = 0.55, 1.3
    elif name == "dusk" or (name == "custom" and level >= 0.25):
        lights = [(58, az0, 0.6), (66, az0 + 15, 0.4)]
        direct = np.array([1.05, 0.78, 0.52]) * 125 * jit(0.15)
        ambient = np.array([0.95, 0.78, 1.10]) * 0.42
        gain, read = 1.1, 2.4
    else:  # night: two lamps of different colour from different sides
        lights = [(12, az0, 0.55), (28, az0 + 160, 0.45)]
        direct = np.array([1.0, 0.86, 0.62]) * 62 * jit(0.15)
        ambient = np.array([0.70, 0.85, 1.05]) * 0.46
        gain, read = 2.4, 4.2
    if name == "custom":  # brightness follows the level within the chosen family
        direct = direct * (0.55 + 0.9 * level)
    return dict(lights=lights, direct=direct, ambient=ambient, gain=gain, read=read)


def fabric(rig, rng):
    X, Y = rig.X, rig.Y
    p = rng.uniform(0.5, 0.65)  # twill period, cm
    ph = rng.uniform(0, 2 * math.pi, 3)
    twill = 0.035 * np.sin(2 * math.pi * (X + Y) / p + ph[0]) + 0.02 * np.sin(
        2 * math.pi * (X - 0.3 * Y) / (p * 1.7) + ph[1])
    low = cv2.GaussianBlur(rng.standard_normal((rig.h, rig.w)).astype(np.float32), (0, 0), 18)
    low = low / (np.abs(low).max() + 1e-6) * 0.06
    # quilted diamond seams every ~6 cm along +-30 degrees
    period = rng.uniform(5.5, 7.0)
    s1 = (X * math.cos(math.radians(30)) + Y * math.sin(math.radians(30))) / period + ph[2]
    s2 = (X * math.cos(math.radians(150)) + Y * math.sin(math.radians(150))) / period
    seam = np.maximum(np.exp(-((s1 - np.round(s1)) * period / 0.12) ** 2),
                      np.exp(-((s2 - np.round(s2)) * period / 0.12) ** 2))
    alb = 0.9 + twill + low - 0.16 * seam
    tint = np.array([1.0, 0.98, 0.93]) * rng.uniform(0.95, 1.03, 3)  # creamy fabric (BGR later)
    return alb.astype(np.float32), tint


SKIN = [np.array(c) for c in ([0.96, 0.78, 0.66], [0.88, 0.66, 0.52], [0.78, 0.56, 0.42],
                              [0.66, 0.46, 0.33], [0.52, 0.36, 0.26], [0.42, 0.29, 0.21])]


def soft_blur(c, sigma):
    """Gaussian blur; wide kernels are applied at reduced resolution (same result to within a
    grey level, a fraction of the cost)."""
    k = int(sigma // 3)
    if k < 2:
        return cv2.GaussianBlur(c, (0, 0), sigma)
    h, w = c.shape
    small = cv2.resize(c, (max(1, w // k), max(1, h // k)), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / k)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)


def compose(rig, parts, light, rng, distract=False):
    """Returns BGR uint8 image, shadow mask, contact mask (bool, image px)."""
    ppc = rig.px_per_cm
    occ_total = np.zeros((rig.h, rig.w), np.float32)
    contact_cov = np.zeros((rig.h, rig.w), np.float32)
    for zen, az, wgt in light["lights"]:
        occ = np.zeros((rig.h, rig.w), np.float32)
        t = math.tan(math.radians(zen))
        for p in parts:
            if p.contact:
                c = p.cover((0.0, 0.0))
                occ = np.maximum(occ, c)
                continue
            sh = (p.height * t * math.cos(math.radians(az)), p.height * t * math.sin(math.radians(az)))
            c = p.cover(sh)
            sigma = (0.25 + 0.16 * p.height) * ppc
            c = soft_blur(c, sigma)
            occ = np.maximum(occ, c * 0.95 * math.exp(-p.height / 30.0))
        occ_total += wgt * occ
    for p in parts:
        if p.contact:
            contact_cov = np.maximum(contact_cov, p.cover((0.0, 0.0)))
    if distract:  # far object: big, soft, faint, never ground truth
        c = (rng.uniform(-20, 20), rng.uniform(-10, 10))
        blob = ellipse(rig, c, rng.uniform(6, 15), rng.uniform(6, 15))
        blob = soft_blur(blob, 6 * ppc) * rng.uniform(0.15, 0.35)
        occ_vis = np.maximum(occ_total, blob)
    else:
        occ_vis = occ_total
    return occ_total, occ_vis, contact_cov


def finish(rig, occ_vis, contact_cov, light, skin, rng, alb, tint):
    f32 = np.float32
    direct = light["direct"].astype(f32)  # RGB
    amb = light["ambient"].astype(f32)
    tint = np.asarray(tint, f32)
    skin = np.asarray(skin, f32)
    dm = f32(direct.mean())
    lit = alb[..., None] * (amb[None, None, :] * dm + direct[None, None, :]
                            * (1 - occ_vis[..., None]))
    lit *= tint[None, None, :]
    # contact: skin seen through the fabric, lit by the transmitted light
    full = alb[..., None] * ((direct + amb * dm) * tint)[None, None, :]
    skin_col = full * (skin * f32(rng.uniform(0.24, 0.34)))[None, None, :]
    img = lit * (1 - contact_cov[..., None]) + skin_col * contact_cov[..., None]
    img *= rig.vignette[..., None]
    dark = np.array([9.0, 8.0, 10.0], f32)
    img = img * rig.vis_f[..., None] + dark * (1 - rig.vis_f[..., None])
    # noise: shot (signal dependent) + read + row banding, then JPEG round trip
    g, rd = light["gain"], light["read"]
    img = img + rng.standard_normal(img.shape, dtype=f32) * np.sqrt(
        f32(g) * np.maximum(img, 0) + f32(rd * rd))
    img = img + rng.standard_normal((rig.h, 1, 1), dtype=f32) * f32(rd * 0.35)
    img = np.clip(np.round(img), 0, 255).astype(np.uint8)[..., ::-1]  # RGB -> BGR
    q = int(rng.integers(68, 93))
    ok, enc = cv2.imencode(".jpg", np.ascontiguousarray(img), [cv2.IMWRITE_JPEG_QUALITY, q])
    if not ok:
        raise Fail("JPEG encoding failed")
    return cv2.imdecode(enc, cv2.IMREAD_COLOR)


def truth(rig, occ_total, contact_cov):
    shadow = (occ_total >= 0.5) & rig.visible
    contact = (contact_cov >= 0.5) & rig.visible
    shadow |= contact
    sb = cv2.boundingRect(shadow.astype(np.uint8)) if shadow.any() else None
    cb = cv2.boundingRect(contact.astype(np.uint8)) if contact.any() else None
    cp = None
    if cb is not None:
        ys, xs = np.nonzero(contact)
        cp = (float(xs.mean()), float(ys.mean()))
    return sb, cb, cp


# --------------------------------------------------------------------------------------------
# Users and scenes

def make_user(uid, sils, rng):
    pools = {}
    for pose, lst in sils.items():
        idx = np.arange(len(lst))
        pools[pose] = [lst[i] for i in idx]  # every body draws from all silhouettes
    return dict(id=uid, scale=rng.uniform(0.88, 1.1) * SCALE, arm=rng.uniform(5.2, 7.4) * SCALE,
                skin=SKIN[int(rng.integers(0, len(SKIN)))] * rng.uniform(0.95, 1.05, 3),
                mirror=bool(rng.integers(0, 2)), pools=pools)


def pick(user, pose, rng):
    pool = user["pools"][pose]
    return pool[int(rng.integers(0, len(pool)))]


def hand_parts(rig, user, pose, rng, wrist, angle, height, contact_mode):
    """Hand + forearm. contact_mode: 'all' (whole hand at 0), 'tip' (fingertip only), 'none'."""
    sil = pick(user, pose, rng)
    mirror = user["mirror"] ^ bool(rng.integers(0, 5) == 0)
    sc = user["scale"] * rng.uniform(0.95, 1.05)
    cov = lambda s, sil=sil: sil_coverage(rig, sil, pose, sc, wrist, angle, mirror, s)
    parts = []
    if contact_mode == "all":
        parts.append(Part(cov, 0.0, contact=True))
        wh = 0.8
    elif contact_mode == "tip":
        base = cov((0.0, 0.0))
        ys, xs = np.nonzero(base > 0.5)
        if len(xs) == 0:
            return None
        # fingertip = hand pixel farthest from the wrist
        wu, wv = wrist_px(rig, wrist)
        d = np.hypot(xs - wu, ys - wv)
        k = int(np.argmax(d))
        tip = (xs[k], ys[k])
        r = 1.6 * rig.px_per_cm * sc
        uu, vv = np.meshgrid(np.arange(rig.w), np.arange(rig.h))
        near = (np.hypot(uu - tip[0], vv - tip[1]) <= r).astype(np.float32)
        tipmask = base * near
        parts.append(Part(lambda s, t=tipmask: t, 0.0, contact=True))
        rest_h = rng.uniform(1.5, 3.0)
        parts.append(Part(lambda s, cov=cov, n=near: cov(s) * (1 - n), rest_h))
        wh = rest_h + 1.0
    else:
        parts.append(Part(cov, height))
        wh = height + 0.8
    parts += arm_parts(rig, wrist, angle, user["arm"], wh, rng.uniform(12, 35))
    return parts


def wrist_px(rig, wrist):
    d = (rig.X - wrist[0]) ** 2 + (rig.Y - wrist[1]) ** 2
    k = int(np.argmin(d))
    return k % rig.w, k // rig.w


def gesture_parts(rig, user, cls, rng):
    if cls == "nothing":
        return []
    if cls in ("palm", "point", "punch"):
        ang = rng.uniform(-40, 40)
        a = math.radians(ang)
        L = POSE_LEN_CM[cls] * user["scale"]
        centre = (rng.uniform(-22, 22), rng.uniform(-10, 8))
        wrist = (centre[0] - math.sin(a) * L / 2, centre[1] + math.cos(a) * L / 2)
        return hand_parts(rig, user, cls, rng, wrist, ang, 0.0,
                          "tip" if cls == "point" else "all")
    if cls == "two_hands":
        parts = []
        sep = rng.uniform(11, 20) * SCALE
        for side in (-1, 1):
            ang = side * rng.uniform(0, 30)
            a = math.radians(ang)
            L = POSE_LEN_CM["palm"] * user["scale"]
            c = (side * sep + rng.uniform(-3, 3) * SCALE, rng.uniform(-8, 6))
            wrist = (c[0] - math.sin(a) * L / 2, c[1] + math.cos(a) * L / 2)
            u = dict(user, mirror=(side < 0))
            parts += hand_parts(rig, u, "palm", rng, wrist, ang, 0.0, "all")
        return parts
    if cls == "hug":
        cy = rng.uniform(4, 14)
        cx = rng.uniform(-6, 6)
        ax, ay = rng.uniform(15, 21) * SCALE, rng.uniform(9, 13) * SCALE
        parts = [Part(lambda s, c=(cx, cy), ax=ax, ay=ay: ellipse(rig, c, ax, ay, s), 0.0, True),
                 Part(lambda s, c=(cx, cy + 4), ax=ax * 1.25, ay=ay * 1.3:
                      ellipse(rig, c, ax, ay, s), 4.0)]
        for side in (-1, 1):  # arms wrapping round from the sides, hands on the skin
            ang = side * rng.uniform(70, 100)
            wrist = (cx + side * (ax + rng.uniform(4, 10) * SCALE), cy - rng.uniform(2, 9) * SCALE)
            a = math.radians(ang)
            u = dict(user, mirror=(side < 0))
            parts += hand_parts(rig, u, "palm", rng, wrist, ang, 0.0, "all")
        return parts
    raise Fail(f"unknown gesture class {cls}")


# --------------------------------------------------------------------------------------------
# Writers

def fmt(v, nd):
    s = f"{v:.{nd}f}"
    s = s.rstrip("0").rstrip(".") if "." in s else s
    return "0" if s in ("-0", "") else s


def row_text(file_name, cls, user, lighting, level, session, idx, ts, sb, cb, cp, ppc, extra=None):
    f = [file_name, cls, str(user), lighting, fmt(level, 4), session, str(idx), fmt(ts, 3)]
    f += [str(v) for v in sb] if sb else [""] * 4
    f += [str(v) for v in cb] if cb else [""] * 4
    f += [fmt(cp[0], 3), fmt(cp[1], 3)] if cp else ["", ""]
    f.append(fmt(ppc, 5))
    if extra:
        f += extra
    return ",".join(f)


def write_png(path, img):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp.png"
    if not cv2.imwrite(tmp, img):
        raise Fail(f"cannot write '{tmp}'")
    os.replace(tmp, path)


def write_text(path, lines):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def rng_for(seed, *keys):
    return np.random.default_rng([seed] + [abs(hash_key(k)) for k in keys])


def hash_key(k):
    h = 1469598103934665603
    for ch in str(k).encode():
        h = ((h ^ ch) * 1099511628211) % (1 << 63)
    return h


_CTX = {}  # per-process state (rigs, silhouettes, seed); set before the worker pool forks


def _map(fn, tasks, workers):
    if workers <= 1:
        return [fn(t) for t in tasks]
    import multiprocessing as mp
    with mp.get_context("fork").Pool(workers) as pool:
        return pool.map(fn, tasks, chunksize=1)


def _gesture_session(task):
    u, lighting = task
    out, seed, sils, per_user, rig = (_CTX[k] for k in ("out", "seed", "sils", "per_user", "robot"))
    user = make_user(u, sils, rng_for(seed, "user", u))
    session = f"u{u}_{lighting}"
    idx = 0
    srng = rng_for(seed, "session", u, lighting)
    alb, tint = fabric(rig, srng)
    lines = []
    for b, cls in enumerate(GESTURES):
        if NEEDS[cls] is not None and NEEDS[cls] not in sils:
            continue
        for k in range(per_user):
            rng = rng_for(seed, "g", u, lighting, cls, k)
            light = light_preset(lighting, LEVEL[lighting], rng)
            parts = gesture_parts(rig, user, cls, rng) or []
            occ, occ_vis, con = compose(rig, parts, light, rng, rng.uniform() < 0.3)
            img = finish(rig, occ_vis, con, light, user["skin"], rng, alb, tint)
            sb, cb, cp = truth(rig, occ, con)
            name = f"{cls}/{session}_{idx:04d}.png"
            write_png(os.path.join(out, "gestures", name), img)
            ts = idx * 100.0 + b * 3000.0
            lines.append(row_text(name, cls, u, lighting, LEVEL[lighting], session, idx, ts,
                                  sb, cb, cp, rig.px_per_cm))
            idx += 1
    return lines


def render_gestures(out, seed, sils, users, per_user, workers=1):
    _CTX.update(out=out, seed=seed, sils=sils, per_user=per_user, robot=Rig(**ROBOT))
    tasks = [(u, lg) for u in range(users) for lg in ("daylight", "dusk", "night")]
    lines = [HEADER]
    for ls in _map(_gesture_session, tasks, workers):
        lines += ls
    write_text(os.path.join(out, "gestures", "metadata.csv"), lines)
    return len(lines) - 1


def _empty_skin_session(task):
    """Three frames of a gesture session's empty skin: the session's fabric (the same draw as
    _gesture_session's), a light drawn per frame as the gesture frames' are, from a stream of
    its own (the gesture frames are unchanged), no body."""
    u, lighting = task
    out, seed, rig = (_CTX[k] for k in ("out", "seed", "robot"))
    session = f"u{u}_{lighting}"
    alb, tint = fabric(rig, rng_for(seed, "session", u, lighting))
    for k in range(3):
        rng = rng_for(seed, "empty_skin", u, lighting, k)
        light = light_preset(lighting, LEVEL[lighting], rng)
        _, occ_vis, con = compose(rig, [], light, rng)
        img = finish(rig, occ_vis, con, light, SKIN[0], rng, alb, tint)
        write_png(os.path.join(out, "gestures", "empty_skin", f"{session}_{k}.png"), img)
    return session


def render_empty_skin(out, seed, users, workers=1):
    """OUT/gestures/empty_skin/<session>_<k>.png (k = 0..2) for every session render_gestures
    writes (the layout of ss_gesture_data --empty-skin, docs/dataset_format.md, without the
    .calib files: tools/realhand/score.sh makes those with ss_calibrate --empty)."""
    _CTX.update(out=out, seed=seed, robot=Rig(**ROBOT))
    tasks = [(u, lg) for u in range(users) for lg in ("daylight", "dusk", "night")]
    return len(_map(_empty_skin_session, tasks, workers))


def track_parts(rig, user, cat, rng, centre=None, angle=None):
    ang = rng.uniform(-35, 35) if angle is None else angle
    a = math.radians(ang)
    pose = {"palm": "palm", "fist": "punch", "finger": "point"}.get(cat)
    if cat == "hover":
        have = [p for p in ("palm", "punch", "point") if p in user["pools"]]
        pose = have[int(rng.integers(0, len(have)))]
    L = POSE_LEN_CM[pose] * user["scale"]
    if centre is None:
        centre = (rng.uniform(-4, 4), rng.uniform(-6, 0))
    if pose == "point" and cat != "hover":  # put the fingertip in view
        centre = (centre[0], centre[1] + 2)
    wrist = (centre[0] - math.sin(a) * L / 2, centre[1] + math.cos(a) * L / 2)
    if cat == "hover":
        return hand_parts(rig, user, pose, rng, wrist, ang, rng.uniform(*HOVER_CM), "none")
    return hand_parts(rig, user, pose, rng, wrist, ang, 0.0, "tip" if cat == "finger" else "all")


def _tracking_frame(task):
    cat, n = task
    out, seed, users, rig = (_CTX[k] for k in ("out", "seed", "tusers", "box"))
    rng = rng_for(seed, "t", cat, n)
    user = users[n % len(users)]
    if cat == "nothing":  # several light levels, recorded as custom
        level = float(np.round(rng.uniform(0, 1), 3))
        lighting = "custom"
    else:
        lighting = ("daylight", "dusk", "night")[n % 3]
        level = LEVEL[lighting]
    light = light_preset(lighting, level, rng)
    alb, tint = fabric(rig, rng)
    parts = [] if cat == "nothing" else (track_parts(rig, user, cat, rng) or [])
    occ, occ_vis, con = compose(rig, parts, light, rng, rng.uniform() < 0.3)
    img = finish(rig, occ_vis, con, light, user["skin"], rng, alb, tint)
    sb, cb, cp = truth(rig, occ, con)
    name = f"{cat}/{cat}_{n}.png"
    write_png(os.path.join(out, "tracking", name), img)
    return row_text(name, cat, user["id"], lighting, level, "tracking", n, 1000.0 * n, sb, cb, cp,
                    rig.px_per_cm)


def render_tracking(out, seed, sils, n_contact, n_empty, n_hover, n_users=8, workers=1):
    _CTX.update(out=out, seed=seed, box=Rig(**BOX),
                tusers=[make_user(100 + u, sils, rng_for(seed, "tuser", u)) for u in range(n_users)])
    counts = {"nothing": n_empty, "hover": n_hover, "palm": n_contact, "fist": n_contact,
              "finger": n_contact}
    tasks = [(cat, n) for cat in TRACK for n in range(counts[cat])
             if NEEDS[cat] is None or NEEDS[cat] in sils]
    lines = [HEADER] + _map(_tracking_frame, tasks, workers)
    write_text(os.path.join(out, "tracking", "metadata.csv"), lines)
    return len(lines) - 1


def ease(t, kind):
    if kind == 0:
        return t
    return 0.5 - 0.5 * math.cos(math.pi * t)


SLIDE_COMBOS = [(g, d) for g in ("palm", "finger") for d in DIRECTIONS]


def _slide_sequence(q):
    out, seed, sils, rig = (_CTX[k] for k in ("out", "seed", "sils", "box"))
    combos = SLIDE_COMBOS
    fps = 30.0
    gesture, direction = combos[q % len(combos)]
    rng = rng_for(seed, "s", q)
    user = make_user(200 + q, sils, rng_for(seed, "suser", q))
    lighting = ("daylight", "dusk", "night")[q % 3]
    level = LEVEL[lighting]
    light = light_preset(lighting, level, rng)
    alb, tint = fabric(rig, rng)
    dist = rng.uniform(5, 13)
    dur = rng.uniform(0.2, 1.0)
    nf = max(2, int(round(dur * fps)) + 1)
    kind = int(rng.integers(0, 2))
    dx, dy = DIRECTIONS[direction]
    start = (rng.uniform(-3, 3) - dx * dist / 2, rng.uniform(-4, 0) - dy * dist / 2)
    ang = rng.uniform(-30, 30)
    wob = rng.uniform(0.1, 0.5)
    folder = f"{direction}/{gesture}_{q}"
    lines = [HEADER + ",gesture,direction"]
    cat = "palm" if gesture == "palm" else "finger"
    # one fixed body per sequence: the same silhouette for every frame
    srng_state = int(rng.integers(0, 1 << 62))
    for i in range(nf):
        t = i / (nf - 1)
        s = ease(t, kind) * dist
        side = wob * math.sin(math.pi * t)
        c = (start[0] + dx * s - dy * side, start[1] + dy * s + dx * side)
        frng = np.random.default_rng([srng_state, i])
        prng = np.random.default_rng(srng_state)  # same silhouette/scale choices each frame
        parts = track_parts(rig, user, cat, prng, centre=c, angle=ang) or []
        occ, occ_vis, con = compose(rig, parts, light, frng, False)
        img = finish(rig, occ_vis, con, light, user["skin"], frng, alb, tint)
        sb, cb, cp = truth(rig, occ, con)
        name = f"frame_{i:04d}.png"
        write_png(os.path.join(out, "slides", folder, name), img)
        lines.append(row_text(name, direction, user["id"], lighting, level, folder, i,
                              1000.0 * i / fps, sb, cb, cp, rig.px_per_cm,
                              [gesture, direction]))
    write_text(os.path.join(out, "slides", folder, "metadata.csv"), lines)
    return (",".join([folder, gesture, direction, str(nf), fmt(dist, 3), fmt(fps, 3),
                      str(user["id"]), lighting, fmt(level, 4)]), nf)


def render_slides(out, seed, sils, n_seq, workers=1):
    _CTX.update(out=out, seed=seed, sils=sils, box=Rig(**BOX))
    seqs = [q for q in range(n_seq)
            if SLIDE_COMBOS[q % len(SLIDE_COMBOS)][0] == "palm" or "point" in sils]
    res = _map(_slide_sequence, seqs, workers)
    seq_lines = ["sequence,gesture,direction,num_frames,distance_cm,fps,user,lighting,lighting_level"]
    seq_lines += [r[0] for r in res]
    write_text(os.path.join(out, "slides", "sequences.csv"), seq_lines)
    return len(seqs), sum(r[1] for r in res)


def main(argv):
    ap = argparse.ArgumentParser(prog="render.py", description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--users", type=int, default=5)
    ap.add_argument("--frames-per-user", type=int, default=4)
    ap.add_argument("--tracking-contact", type=int, default=60)
    ap.add_argument("--tracking-empty", type=int, default=120)
    ap.add_argument("--tracking-hover", type=int, default=120)
    ap.add_argument("--slides", type=int, default=40)
    ap.add_argument("--silhouettes", "--hands", dest="silhouettes", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..", "data", "realhand"),
        help="folder of silhouettes with manifest.csv (file,pose[,split]); default data/realhand")
    ap.add_argument("--split", default=None,
                    help="use only manifest rows whose split column equals this (e.g. heldout)")
    ap.add_argument("--scale", type=float, default=1.0,
                    help="body size multiplier: hands, arms, torso S times larger (default 1)")
    ap.add_argument("--hover-range", default="2.5,15", metavar="LO,HI",
                    help="height of hovering hands above the skin in tracking frames, cm "
                         "(default 2.5,15)")
    ap.add_argument("--only", choices=["gestures", "tracking", "slides", "empty_skin"],
                    help="render one part; empty_skin (never part of the default): three "
                         "empty-skin frames per gesture session, gestures/empty_skin/")
    ap.add_argument("--workers", type=int, default=1,
                    help="worker processes; the files are identical for any value")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args(argv)
    for k in ("users", "frames_per_user", "slides", "workers"):
        if getattr(a, k) < 1:
            ap.error(f"--{k.replace('_', '-')} must be >= 1")
    for k in ("tracking_contact", "tracking_empty", "tracking_hover", "seed"):
        if getattr(a, k) < 0:
            ap.error(f"--{k.replace('_', '-')} must be >= 0")
    if not (math.isfinite(a.scale) and 0.25 <= a.scale <= 4.0):
        ap.error("--scale must be a number in [0.25, 4]")
    try:
        lo, hi = (float(v) for v in a.hover_range.split(","))
    except ValueError:
        ap.error(f"--hover-range '{a.hover_range}' is not LO,HI (two numbers in cm)")
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi <= 50):
        ap.error("--hover-range needs 0 < LO <= HI <= 50 (cm)")
    global SCALE, HOVER_CM
    SCALE = a.scale
    HOVER_CM = (lo, hi)
    try:
        sils = load_silhouettes(a.silhouettes, a.split)
        missing = [p for p in ("palm", "point", "punch") if p not in sils]
        if missing:
            print(f"no silhouettes of {', '.join(missing)}: classes needing them are skipped")
        if a.only in (None, "gestures"):
            n = render_gestures(a.out, a.seed, sils, a.users, a.frames_per_user, a.workers)
            print(f"gestures: {n} frames")
        if a.only in (None, "tracking"):
            n = render_tracking(a.out, a.seed, sils, a.tracking_contact, a.tracking_empty,
                                a.tracking_hover, workers=a.workers)
            print(f"tracking: {n} frames")
        if a.only == "empty_skin":
            n = render_empty_skin(a.out, a.seed, a.users, a.workers)
            print(f"empty_skin: {n} sessions, 3 frames each")
        if a.only in (None, "slides"):
            q, n = render_slides(a.out, a.seed, sils, a.slides, a.workers)
            print(f"slides: {q} sequences, {n} frames")
    except Fail as e:
        sys.stderr.write(f"render.py: {e}\n")
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
