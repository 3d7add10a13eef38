//! Named regions of the face as soft masks (0–1), built from the landmarks: where the regional
//! biology, the default feature fields and the expression library apply. Sizes are adult
//! anthropometry (Farkas 1994) unless noted; borders blend over a few millimetres.

use crate::landmarks::Landmarks;
use glam::{Vec2, Vec3};

/// Every region, in a fixed order (the order of [`Regions::weights`]).
pub const REGIONS: [&str; 16] = [
    "scalp",
    "forehead",
    "eyebrows",
    "periorbital",
    "eyelids",
    "nose",
    "cheeks",
    "ears",
    "upper_lip",
    "beard",
    "lips",
    "chin",
    "neck",
    "face",
    "mouth_interior",
    "eye_sockets",
];

/// Index of a region name in [`REGIONS`].
pub fn index(name: &str) -> Option<usize> {
    REGIONS.iter().position(|r| *r == name)
}

/// [`index`] at compile time (a name that is no region fails the build): per-texel code reads
/// weights by constant index, `w[region!("cheeks")]`.
pub const fn index_const(name: &str) -> usize {
    let mut k = 0;
    while k < REGIONS.len() {
        let (a, b) = (REGIONS[k].as_bytes(), name.as_bytes());
        if a.len() == b.len() {
            let mut i = 0;
            while i < a.len() && a[i] == b[i] {
                i += 1;
            }
            if i == a.len() {
                return k;
            }
        }
        k += 1;
    }
    panic!("no such region")
}

/// The index of a region name in [`REGIONS`], checked at compile time.
#[macro_export]
macro_rules! region {
    ($name:literal) => {
        const { $crate::regions::index_const($name) }
    };
}

#[inline]
pub(crate) fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Piecewise-linear interpolation through (x, y) knots sorted by x, clamped at the ends.
fn pwl(knots: &[(f32, f32)], x: f32) -> f32 {
    if x <= knots[0].0 {
        return knots[0].1;
    }
    for w in knots.windows(2) {
        if x <= w[1].0 {
            let t = (x - w[0].0) / (w[1].0 - w[0].0);
            return w[0].1 + t * (w[1].1 - w[0].1);
        }
    }
    knots[knots.len() - 1].1
}

/// UV rectangle [u0, v0, u1, v1] of a chart that is not skin (mouth cavity, eye sockets).
pub type Rect = [f32; 4];

/// The regions of one head: landmark-derived constants plus the non-skin UV charts.
#[derive(Clone, Debug)]
pub struct Regions {
    lm: Landmarks,
    /// The landmarks `weights` reads, looked up once (it runs per texel).
    at: Points,
    /// Depth of the head's vertical axis (mean of the ears' z).
    axis_z: f32,
    /// Non-skin charts: mouth cavity, then eye sockets.
    mouth_charts: Vec<Rect>,
    socket_charts: Vec<Rect>,
}

/// One side's landmarks (left: +x, right: −x).
#[derive(Clone, Copy, Debug)]
pub struct Side {
    /// Eye centre.
    pub eye: Vec3,
    /// Inner canthus.
    pub canthus_inner: Vec3,
    /// Outer canthus.
    pub canthus_outer: Vec3,
    /// Ear.
    pub ear: Vec3,
    /// Mouth corner.
    pub mouth_corner: Vec3,
}

/// The landmarks the region weights read, by field instead of by name.
#[derive(Clone, Copy, Debug)]
struct Points {
    left: Side,
    right: Side,
    nose_tip: Vec3,
    subnasale: Vec3,
    chin: Vec3,
    menton: Vec3,
    hairline: Vec3,
}

impl Points {
    fn of(lm: &Landmarks) -> Points {
        let side = |s: &str| Side {
            eye: lm.get(&format!("eye_centre_{s}")),
            canthus_inner: lm.get(&format!("canthus_inner_{s}")),
            canthus_outer: lm.get(&format!("canthus_outer_{s}")),
            ear: lm.get(&format!("ear_{s}")),
            mouth_corner: lm.get(&format!("mouth_corner_{s}")),
        };
        Points {
            left: side("left"),
            right: side("right"),
            nose_tip: lm.get("nose_tip"),
            subnasale: lm.get("subnasale"),
            chin: lm.get("chin"),
            menton: lm.get("menton"),
            hairline: lm.get("hairline"),
        }
    }
}

/// Region weights at one point, in [`REGIONS`] order.
pub type Weights = [f32; REGIONS.len()];

impl Regions {
    /// Regions from landmarks (all of [`crate::landmarks::NAMES`]) and the UV rectangles of
    /// non-skin charts (empty for user meshes without such charts).
    pub fn new(lm: Landmarks, mouth_charts: Vec<Rect>, socket_charts: Vec<Rect>) -> Self {
        let axis_z = 0.5 * (lm.get("ear_left").z + lm.get("ear_right").z);
        Self {
            at: Points::of(&lm),
            lm,
            axis_z,
            mouth_charts,
            socket_charts,
        }
    }

    /// True at texture coordinates inside an eye-socket chart (the lids' inner surfaces and the
    /// conjunctiva behind them).
    pub fn in_socket(&self, uv: Vec2) -> bool {
        Self::in_rects(&self.socket_charts, uv) > 0.0
    }

    /// The landmarks the regions follow.
    pub fn landmarks(&self) -> &Landmarks {
        &self.lm
    }

    /// The hairline landmark.
    pub fn hairline(&self) -> Vec3 {
        self.at.hairline
    }

    /// The subnasale landmark.
    pub fn subnasale(&self) -> Vec3 {
        self.at.subnasale
    }

    /// The landmarks of the side of the face at x (left for x ≥ 0), looked up once.
    pub fn side(&self, x: f32) -> &Side {
        if x >= 0.0 {
            &self.at.left
        } else {
            &self.at.right
        }
    }

    /// Frontness: the cosine of the point's azimuth about the head's vertical axis (1 straight
    /// ahead, 0 at the sides, −1 at the back).
    pub fn azimuth_cos(&self, p: Vec3) -> f32 {
        let z = p.z - self.axis_z;
        z / (p.x * p.x + z * z).sqrt().max(1e-6)
    }

    /// Height of the scalp hairline at azimuth cosine `c`: the trichion in front, receding at the
    /// temples, above the ears, down to the nape (authored on the landmarks).
    pub fn hairline_y(&self, c: f32) -> f32 {
        let t = self.at.hairline.y;
        let ear = 0.5 * (self.at.left.ear.y + self.at.right.ear.y);
        pwl(
            &[
                (-1.0, ear - 50.0),
                (-0.5, ear - 25.0),
                (-0.15, ear + 35.0),
                (0.2, ear + 40.0),
                (0.55, t - 14.0),
                (0.85, t),
            ],
            c,
        )
    }

    fn in_rects(rects: &[Rect], uv: Vec2) -> f32 {
        let inside = rects
            .iter()
            .any(|r| uv.x >= r[0] && uv.x <= r[2] && uv.y >= r[1] && uv.y <= r[3]);
        if inside {
            1.0
        } else {
            0.0
        }
    }

    /// Weights of every region at surface point `p` with texture coordinate `uv`.
    pub fn weights(&self, p: Vec3, uv: Vec2) -> Weights {
        let mut w: Weights = [0.0; REGIONS.len()];
        w[region!("mouth_interior")] = Self::in_rects(&self.mouth_charts, uv);
        w[region!("eye_sockets")] = Self::in_rects(&self.socket_charts, uv);
        let q = self.point_at(p, &w);
        (w[region!("ears")], w[region!("scalp")]) = self.ears_and_scalp(&q);
        (
            w[region!("eyelids")],
            w[region!("eyebrows")],
            w[region!("periorbital")],
        ) = eye_area(&q);
        w[region!("nose")] = nose(&q, &w);
        w[region!("lips")] = lips(&q);
        w[region!("upper_lip")] = upper_lip(&q, &w);
        w[region!("chin")] = chin(&q, &w);
        w[region!("neck")] = neck(&q, &w);
        w[region!("cheeks")] = cheeks(&q, &w);
        w[region!("forehead")] = forehead(&q, &w);
        w[region!("beard")] = beard(&q, &w);
        w[region!("face")] = face(&q, &w);
        w
    }

    /// What every region's weight reads at `p`, whose non-skin weights `w` holds: its side,
    /// frontness and skin, and the landmark heights several regions share.
    fn point_at(&self, p: Vec3, w: &Weights) -> At<'_> {
        let at = &self.at;
        let skin = 1.0 - w[region!("mouth_interior")].max(w[region!("eye_sockets")]);
        let c = self.azimuth_cos(p);
        let (x, y) = (p.x, p.y);
        let (side, this) = if x >= 0.0 {
            ("left", &at.left)
        } else {
            ("right", &at.right)
        };
        let s = Landmarks::side_sign(side);
        let ear_y = 0.5 * (at.left.ear.y + at.right.ear.y);
        // The jaw line runs from under the menton to 38 mm below the ears.
        let jaw_y = pwl(
            &[
                (-1.0, ear_y - 50.0),
                (0.0, ear_y - 38.0),
                (0.5, 0.5 * (at.menton.y + ear_y) - 15.0),
                (1.0, at.menton.y - 2.0),
            ],
            c,
        );
        At {
            p,
            x,
            y,
            ax: x * s,
            s,
            c,
            front: smoothstep(0.1, 0.35, c),
            skin,
            this,
            at,
            mouth_y: 0.5 * (at.left.mouth_corner.y + at.right.mouth_corner.y),
            ear_y,
            jaw_y,
        }
    }

    /// Ears — the auricle, ~63 × 35 mm (Farkas 1994), standing out from the side of the head —
    /// and the scalp above the hairline.
    fn ears_and_scalp(&self, q: &At) -> (f32, f32) {
        let (p, y, skin, ear_p) = (q.p, q.y, q.skin, q.this.ear);
        let ey = (y - ear_p.y) / 33.0;
        let ez = (p.z - ear_p.z) / 20.0;
        let ears = skin
            * smoothstep(1.1, 0.9, (ey * ey + ez * ez).sqrt())
            * smoothstep(ear_p.x.abs() - 16.0, ear_p.x.abs() - 11.0, q.ax);

        let hy = self.hairline_y(q.c);
        let scalp = skin * (1.0 - ears) * smoothstep(hy - 3.0, hy + 4.0, y);
        (ears, scalp)
    }
}

/// One point's shared quantities for the region weights ([`Regions::weights`]).
struct At<'a> {
    p: Vec3,
    x: f32,
    y: f32,
    /// Distance towards this side.
    ax: f32,
    /// The side's sign (+1 left, −1 right).
    s: f32,
    /// Azimuth cosine ([`Regions::azimuth_cos`]) and the frontness it gives.
    c: f32,
    front: f32,
    /// 1 on skin, 0 on the non-skin charts.
    skin: f32,
    /// This side's landmarks, and all of them.
    this: &'a Side,
    at: &'a Points,
    /// Heights of the mouth line, the ears and the jaw line below this point.
    mouth_y: f32,
    ear_y: f32,
    jaw_y: f32,
}

/// Eyelids, eyebrows and the periorbital ring, as (eyelids, eyebrows, periorbital).
fn eye_area(q: &At) -> (f32, f32, f32) {
    let (p, y, ax, skin) = (q.p, q.y, q.ax, q.skin);
    let (eye, ci, co) = (q.this.eye, q.this.canthus_inner, q.this.canthus_outer);
    // Eyelids: from the canthi ± 2 mm, 13 mm above the eye centre (lid to crease and fold)
    // and 9 mm below (lower lid to the lid–cheek junction).
    let xm = 0.5 * (ci.x + co.x) * q.s;
    let hw = 0.5 * (co.x - ci.x).abs() + 2.0;
    let du = (ax - xm) / hw;
    let dv = if y > eye.y {
        (y - eye.y) / 13.0
    } else {
        (eye.y - y) / 9.0
    };
    let lid_r = (du * du + dv * dv).sqrt();
    let ahead = smoothstep(eye.z - 8.0, eye.z - 2.0, p.z);
    let eyelids = skin * ahead * smoothstep(1.1, 0.9, lid_r);

    // Eyebrows: an arch over the supraorbital rim from 3 mm medial of the inner canthus to
    // 10 mm beyond the outer one; 18–22 mm above the eye centre, 10 mm tall medially
    // tapering to 5 mm at the tail.
    let b0 = ci.x.abs() - 3.0;
    let b1 = co.x.abs() + 10.0;
    let t = (2.0 * (ax - b0) / (b1 - b0) - 1.0).clamp(-1.5, 1.5);
    let brow_y = eye.y + 18.0 + 4.0 * (1.0 - ((t - 0.2) / 1.2).powi(2)).max(0.0);
    let brow_h = 5.0 - 2.5 * (0.5 * (t + 1.0)).clamp(0.0, 1.0);
    let eyebrows = skin
        * q.front
        * smoothstep(1.05, 0.9, t.abs())
        * smoothstep(1.0, 0.7, (y - brow_y).abs() / brow_h);

    // Periorbital: the ring around the lids out to the orbital rim (~12 mm beyond the lids
    // sideways, 20 mm below the eye centre), darker and bluish in many people (Freitag &
    // Cestari 2007, J Cosmet Dermatol 6:211).
    let pv = if y > eye.y {
        (y - eye.y) / 22.0
    } else {
        (eye.y - y) / 21.0
    };
    let pu = (ax - xm) / (hw + 10.0);
    let orbit = ahead * smoothstep(1.1, 0.9, (pu * pu + pv * pv).sqrt());
    let periorbital = (skin * orbit - eyelids - eyebrows).clamp(0.0, 1.0);
    (eyelids, eyebrows, periorbital)
}

/// Nose: 9 mm either side of the midline at the nasion widening to the alae (alar width
/// ~35 mm, Farkas 1994), from 8 mm above the eye centres to the subnasale.
fn nose(q: &At, w: &Weights) -> f32 {
    let (x, y, eye) = (q.x, q.y, q.this.eye);
    let (nose_tip, subnasale) = (q.at.nose_tip, q.at.subnasale);
    let width = pwl(
        &[
            (subnasale.y, 18.0),
            (nose_tip.y, 17.0),
            (eye.y - 12.0, 10.0),
            (eye.y + 8.0, 8.0),
        ],
        y,
    );
    (q.skin
        * q.front
        * smoothstep(1.05, 0.85, x.abs() / width)
        * smoothstep(subnasale.y - 2.0, subnasale.y + 1.0, y)
        * smoothstep(eye.y + 10.0, eye.y + 6.0, y)
        - w[region!("eyelids")])
    .clamp(0.0, 1.0)
}

/// Lips (vermilion): from corner to corner, the upper vermilion 8 mm tall with a cupid's
/// bow, the lower 10 mm (vermilion heights ls–sto ≈ 8, sto–li ≈ 10 mm; Farkas 1994).
fn lips(q: &At) -> f32 {
    let (x, y, mouth_y, mc) = (q.x, q.y, q.mouth_y, q.this.mouth_corner);
    let half = mc.x.abs();
    let lip_h = if y > mouth_y {
        8.0 - 1.5 * (-(x / 4.0).powi(2)).exp() + 1.0 * (-((x.abs() - 6.0) / 4.0).powi(2)).exp()
    } else {
        10.0
    };
    let lip_r = (((y - mouth_y) / lip_h).powi(2) + (x.abs() / half).powf(2.5)).sqrt();
    q.skin * smoothstep(mc.z - 8.0, mc.z - 3.0, q.p.z) * smoothstep(1.1, 0.92, lip_r)
}

/// Upper lip (skin): between the vermilion and the subnasale, as wide as the mouth.
fn upper_lip(q: &At, w: &Weights) -> f32 {
    let (x, y, mouth_y, subnasale) = (q.x, q.y, q.mouth_y, q.at.subnasale);
    let half = q.this.mouth_corner.x.abs();
    (q.skin
        * q.front
        * smoothstep(mouth_y, mouth_y + 6.0, y)
        * smoothstep(subnasale.y + 1.0, subnasale.y - 2.0, y)
        * smoothstep(half + 6.0, half + 1.0, x.abs())
        - w[region!("lips")]
        - w[region!("nose")])
    .clamp(0.0, 1.0)
}

/// Chin: around the pogonion, below the lower lip.
fn chin(q: &At, w: &Weights) -> f32 {
    let cu = q.x / 22.0;
    let cv = (q.y - q.at.chin.y) / 16.0;
    (q.skin * q.front * smoothstep(1.1, 0.9, (cu * cu + cv * cv).sqrt()) - w[region!("lips")])
        .clamp(0.0, 1.0)
}

/// Neck: below the jaw line.
fn neck(q: &At, w: &Weights) -> f32 {
    let jaw_y = q.jaw_y;
    q.skin
        * (1.0 - w[region!("ears")])
        * (1.0 - w[region!("scalp")])
        * smoothstep(jaw_y + 4.0, jaw_y - 4.0, q.y)
}

/// Cheeks: below the lids, beside the nose, above the mouth corners' level, in front of the
/// ears.
fn cheeks(q: &At, w: &Weights) -> f32 {
    let cx = (q.ax - 42.0) / 26.0;
    let cy = (q.y - (q.this.eye.y - 32.0)) / 24.0;
    (q.skin * q.front * smoothstep(1.1, 0.85, (cx * cx + cy * cy).sqrt())
        - w[region!("nose")]
        - w[region!("lips")]
        - w[region!("eyelids")]
        - w[region!("periorbital")]
        - w[region!("upper_lip")])
    .clamp(0.0, 1.0)
}

/// Forehead: above the brows to the hairline, between the temples.
fn forehead(q: &At, w: &Weights) -> f32 {
    let (eye, co) = (q.this.eye, q.this.canthus_outer);
    (q.skin
        * smoothstep(0.35, 0.55, q.c)
        * (1.0 - w[region!("scalp")])
        * smoothstep(eye.y + 20.0, eye.y + 27.0, q.y)
        * smoothstep(co.x.abs() + 16.0, co.x.abs() + 8.0, q.x.abs())
        - w[region!("eyebrows")])
    .clamp(0.0, 1.0)
}

/// Beard area (terminal hair in men): the upper lip, cheeks below a line from the nasolabial
/// region to the sideburns, chin, jaw and upper neck.
fn beard(q: &At, w: &Weights) -> f32 {
    let (y, subnasale, ear_y, jaw_y) = (q.y, q.at.subnasale, q.ear_y, q.jaw_y);
    let half = q.this.mouth_corner.x.abs();
    let top = pwl(
        &[
            (0.0, subnasale.y - 2.0),
            (half + 8.0, subnasale.y - 6.0),
            (45.0, q.this.eye.y - 35.0),
            (62.0, ear_y),
            (75.0, ear_y + 30.0),
        ],
        q.x.abs(),
    );
    (q.skin
        * (1.0 - w[region!("scalp")])
        * (1.0 - w[region!("ears")])
        * smoothstep(-0.1, 0.1, q.c)
        * smoothstep(top + 3.0, top - 3.0, y)
        * smoothstep(jaw_y - 40.0, jaw_y - 25.0, y)
        - w[region!("lips")]
        - w[region!("nose")])
    .clamp(0.0, 1.0)
}

/// The face: skin in front, off the scalp, neck and ears.
fn face(q: &At, w: &Weights) -> f32 {
    (q.skin
        * q.front
        * (1.0 - w[region!("scalp")])
        * (1.0 - w[region!("neck")])
        * (1.0 - w[region!("ears")]))
    .clamp(0.0, 1.0)
}

impl Regions {
    /// Canonical face coordinates of a point, for content authored on a generic face: x in mm
    /// from the midline scaled so the eye centres sit at ±32, y piecewise linear through the
    /// landmarks so the eye line is at 21, the mouth line at −46 and the menton at −96, and
    /// frontness in [0, 1] (1 on the face, 0 at the sides and behind). The rig's expression
    /// library is authored in this frame and follows any head through its landmarks.
    pub fn face_coords(&self, p: Vec3) -> (f32, f32, f32) {
        let lm = &self.lm;
        let eye = 0.5 * (lm.get("eye_centre_left") + lm.get("eye_centre_right"));
        let half_ipd = 0.5 * (lm.get("eye_centre_left").x - lm.get("eye_centre_right").x).abs();
        let mouth = 0.5 * (lm.get("mouth_corner_left").y + lm.get("mouth_corner_right").y);
        let menton = lm.get("menton").y;
        let y = if p.y >= mouth {
            21.0 + (p.y - eye.y) * (21.0 + 46.0) / (eye.y - mouth)
        } else {
            -46.0 + (p.y - mouth) * (96.0 - 46.0) / (mouth - menton)
        };
        let x = (p.x - eye.x) * 32.0 / half_ipd;
        (x, y, smoothstep(0.15, 0.45, self.azimuth_cos(p)))
    }
}
