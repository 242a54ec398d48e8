//! The region a Siemens milling cycle machines, read from its call's arguments. The dry run does not run
//! the cycles (the audit skips calls it cannot find), so their cuts are no moves it sees; the audit's check
//! of the probe point against what the original cuts takes the region instead.
//!
//! A region is a box in the coordinates of the call: the working plane's first and second axis, and the
//! tool axis from the deepest point the cycle reaches up to its reference plane. Where the shape is not a
//! box (a rotated rectangle, a circle, slots on a circle) the box encloses it: for a safety check an
//! overestimate is right. Where the arguments do not give the region (a value the dry run cannot evaluate,
//! one left out that the shape needs, values that make no shape) or the cycle's shape is not in its
//! arguments at all (contour cycles), the answer says why instead of guessing.
//!
//! Parameter orders, and where each comes from (0-based positions in the comments below are 1-based in
//! the manuals):
//!
//! - `CYCLE71`: SINUMERIK 808D ADVANCED Programming and Operating Manual (Milling), 6FC5398-4DP10-0BA7,
//!   07/2018, 12.6.2 "Face milling - CYCLE71" — verified.
//! - `CYCLE72`: SINUMERIK 840D sl / 828D NC programming, Programming Manual 12/2019, 6FC5398-2EP40-0BA0,
//!   3.25 "Programming cycles externally" (the first parameter is the contour's name) — verified.
//! - `POCKET1`: the parameter list of the 840D cycles as reproduced on a public forum (not a Siemens page).
//! - `POCKET3`: a public help text listing it, consistent with the calls in the shop programs.
//! - `CYCLE81` … `CYCLE89`, `CYCLE840`: SINUMERIK 840D/840Di/810D Programming Guide Cycles (PGZ), 11.02,
//!   2.1 (`RTP, RFP, SDIS, DP, DPR` first in every drilling cycle) — verified. They drill where the tool
//!   stands, at the call or, under `MCALL`, after each later move.
//! - `HOLES1`, `HOLES2`, `CYCLE801`: the 840D cycles guide's orders as a public cycle reader and a
//!   public test repeat them (not a Siemens page); consistent with the calls in the shop programs.
//!   `CYCLE802`: the positions' pairs from its third argument on, as the shop programs write them; what its
//!   two leading masks select is not known here, so both readings are covered.
//! - `CYCLE61`, `POCKET2`, `POCKET4`, `CYCLE76`, `CYCLE77`, `SLOT1`, `SLOT2`: the 840D sl / 828D cycles
//!   manuals as known from use; no Siemens page was found to check them against here. The values each
//!   shape needs are checked to make a shape (lengths and radii positive, a blank larger than its spigot),
//!   so an order read wrong tends to end as "unknown" rather than as a wrong box.

/// One argument of a call the dry run skipped.
#[derive(Debug, Clone, PartialEq)]
pub(in crate::vm) enum Arg {
    Num(f64),
    Text,
    /// Left out (`,,`).
    Omitted,
    /// Given, but the dry run cannot evaluate it (a name from definitions it does not have).
    Unknown,
}

/// What a cycle machines, in the coordinates of its call.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(in crate::vm) struct Region {
    /// Ranges on the working plane's first and second axis.
    pub plane: [[f64; 2]; 2],
    /// On the tool axis: the deepest point reached, and the reference plane.
    pub depth: [f64; 2],
    /// What the cycle leaves standing up to the reference plane inside `plane` (a spigot), as a box within
    /// it.
    pub island: Option<[[f64; 2]; 2]>,
}

/// A milling cycle's region, or why it cannot be known.
#[derive(Debug, Clone, PartialEq)]
pub(in crate::vm) enum Extent {
    Known(Region),
    /// A hole pattern's holes, each where the tool drills it.
    Holes(Vec<Region>),
    Unknown(String),
}

/// The region of a call of `name` (upper case) with `args`; `None` for a call that is no milling or
/// drilling cycle known here. `modally`: called by `MCALL` after each later move, where a milling cycle
/// machines at positions the call does not give. `at`: where the tool stands in the working plane (the
/// call's coordinates), where a drilling cycle drills.
pub(in crate::vm) fn extent(
    name: &str,
    args: &[Arg],
    modally: bool,
    at: [f64; 2],
) -> Option<Extent> {
    if let Some((_, why)) = UNKNOWABLE.iter().find(|(n, _)| *n == name) {
        return Some(Extent::Unknown((*why).to_string()));
    }
    if DRILLS.contains(&name) {
        return Some(match drilled_depth(args) {
            Ok(depth) => Extent::Known(hole(at, depth)),
            Err(why) => Extent::Unknown(why),
        });
    }
    let (_, shape) = SHAPES.iter().find(|(n, _)| *n == name)?;
    if modally {
        return Some(Extent::Unknown(
            "it is called modally (MCALL) and machines wherever the later blocks move to".into(),
        ));
    }
    Some(match shape(&Args(args)) {
        Ok(region) => Extent::Known(region),
        Err(why) => Extent::Unknown(why),
    })
}

/// The region of a hole pattern's call (`HOLES1`, `HOLES2`, `CYCLE801`, `CYCLE802`) under `MCALL`: the
/// pattern moves to each of its positions and calls `under`, the cycle `MCALL` made modal, there. `None`
/// for a call that is no hole pattern, or one with no modal call in force (it only positions the tool).
/// `at`: where the tool stands in the working plane, from which positions may be incremental.
pub(in crate::vm) fn pattern_extent(
    name: &str,
    args: &[Arg],
    at: [f64; 2],
    under: Option<&(String, Vec<Arg>)>,
) -> Option<Extent> {
    let (_, positions) = PATTERNS.iter().find(|(n, _)| *n == name)?;
    let (cycle, cycle_args) = under?;
    let points = match positions(&Args(args), at) {
        Ok(points) => points,
        Err(why) => return Some(Extent::Unknown(why)),
    };
    if !DRILLS.contains(&cycle.as_str()) {
        return Some(Extent::Unknown(format!(
            "it calls {cycle}, made modal by MCALL, at each of its positions, where the dry run does not run it"
        )));
    }
    Some(match drilled_depth(cycle_args) {
        Ok(depth) => Extent::Holes(points.into_iter().map(|p| hole(p, depth)).collect()),
        Err(why) => Extent::Unknown(format!("the {cycle} it calls at each position: {why}")),
    })
}

/// The positions of a hole pattern, from its arguments and where the tool stands.
type Positions = fn(&Args, [f64; 2]) -> Result<Vec<[f64; 2]>, String>;

const PATTERNS: &[(&str, Positions)] = &[
    ("HOLES1", row_of_holes),
    ("HOLES2", circle_of_holes),
    ("CYCLE801", grid_of_holes),
    ("CYCLE802", free_positions),
];

/// More holes than any pattern on a part has: a count read wrong, rather than a pattern to enumerate.
const MAX_HOLES: f64 = 10_000.0;

/// Argument `k` as a number of holes: a whole number from 1 up.
fn count(a: &Args, k: usize, what: &str) -> Result<usize, String> {
    let n = a.num(k, what)?;
    if (1.0..=MAX_HOLES).contains(&n) && n.fract() == 0.0 {
        Ok(n as usize)
    } else {
        Err(format!(
            "its parameter {} ({what}) is no number of holes",
            k + 1
        ))
    }
}

/// `HOLES1(SPCA, SPCO, STA1, FDIS, DBH, NUM)`: `NUM` holes on the line through `SPCA`/`SPCO` at the angle
/// `STA1`, the first `FDIS` from that point, the next `DBH` apart.
fn row_of_holes(a: &Args, _at: [f64; 2]) -> Result<Vec<[f64; 2]>, String> {
    let base = a.point(0, "reference point")?;
    let (s, c) = a
        .opt(2, "angle STA1")?
        .unwrap_or(0.0)
        .to_radians()
        .sin_cos();
    let first = a.opt(3, "first hole's distance FDIS")?.unwrap_or(0.0);
    let pitch = a.num(4, "distance between holes DBH")?;
    let n = count(a, 5, "number of holes NUM")?;
    Ok((0..n)
        .map(|i| {
            let d = first + i as f64 * pitch;
            [base[0] + c * d, base[1] + s * d]
        })
        .collect())
}

/// `HOLES2(CPA, CPO, RAD, STA1, INDA, NUM)`: `NUM` holes on the circle `RAD` about `CPA`/`CPO` from the angle
/// `STA1`, `INDA` apart (the full circle divided by `NUM` where `INDA` is 0).
fn circle_of_holes(a: &Args, _at: [f64; 2]) -> Result<Vec<[f64; 2]>, String> {
    let centre = a.point(0, "circle centre")?;
    let radius = a.size(2, "radius RAD")?;
    let start = a.opt(3, "start angle STA1")?.unwrap_or(0.0);
    let n = count(a, 5, "number of holes NUM")?;
    let step = match a.opt(4, "angle between holes INDA")?.unwrap_or(0.0) {
        0.0 => 360.0 / n as f64,
        v => v,
    };
    Ok((0..n)
        .map(|i| {
            let (s, c) = (start + i as f64 * step).to_radians().sin_cos();
            [centre[0] + radius * c, centre[1] + radius * s]
        })
        .collect())
}

/// `CYCLE801(SPCA, SPCO, STA, DIS1, DIS2, NUM1, NUM2)`: a grid of `NUM1` columns `DIS1` apart and `NUM2`
/// rows `DIS2` apart from the reference point `SPCA`/`SPCO`, turned by `STA`.
fn grid_of_holes(a: &Args, _at: [f64; 2]) -> Result<Vec<[f64; 2]>, String> {
    let base = a.point(0, "reference point")?;
    let sta = a.opt(2, "angle STA")?.unwrap_or(0.0);
    let (columns, rows) = (
        count(a, 5, "number of columns NUM1")?,
        count(a, 6, "number of rows NUM2")?,
    );
    if (columns * rows) as f64 > MAX_HOLES {
        return Err(format!(
            "its {columns} × {rows} holes are more than a part has"
        ));
    }
    let (dx, dy) = (
        a.num(3, "distance between columns DIS1")?,
        a.num(4, "distance between rows DIS2")?,
    );
    let (s, c) = sta.to_radians().sin_cos();
    Ok((0..columns * rows)
        .map(|k| {
            let (u, v) = ((k % columns) as f64 * dx, (k / columns) as f64 * dy);
            [base[0] + c * u - s * v, base[1] + s * u + c * v]
        })
        .collect())
}

/// `CYCLE802(mask, mask, X0, Y0, X1, Y1, … X8, Y8, …)`: up to nine positions given by pairs. What the two
/// leading masks select (one digit per position) was not verified here: with every digit 1, the form the
/// Operate screen writes for absolute positions, they are taken as absolute; otherwise both as absolute
/// and as steps from where the tool stands.
fn free_positions(a: &Args, at: [f64; 2]) -> Result<Vec<[f64; 2]>, String> {
    let all_ones = |k: usize| matches!(a.0.get(k), Some(Arg::Num(v)) if *v > 0.0 && v.to_string().bytes().all(|b| b == b'1'));
    let absolute = all_ones(0) && all_ones(1);
    let mut points = Vec::new();
    let mut walked = at;
    for k in 0..9 {
        let i = 2 + 2 * k;
        let x = a.opt(i, &format!("X{k}"))?;
        let y = a.opt(i + 1, &format!("Y{k}"))?;
        match (x, y) {
            (None, None) => continue,
            (Some(x), Some(y)) => {
                walked = [walked[0] + x, walked[1] + y];
                points.push([x, y]);
                if !absolute {
                    points.push(walked);
                }
            }
            _ => return Err(format!("its position {k} gives one coordinate only")),
        }
    }
    if points.is_empty() {
        return Err("it gives no position".into());
    }
    Ok(points)
}

/// Milling cycles whose region their arguments do not give.
const UNKNOWABLE: &[(&str, &str)] = &[
    ("CYCLE72", "it mills along a contour defined elsewhere"),
    (
        "CYCLE63",
        "it mills a pocket bounded by contours defined elsewhere",
    ),
    (
        "CYCLE64",
        "it predrills a pocket bounded by contours defined elsewhere",
    ),
    (
        "CYCLE73",
        "it mills a pocket bounded by contours defined elsewhere",
    ),
    ("CYCLE74", "it takes a pocket's contour defined elsewhere"),
    ("CYCLE75", "it takes an island's contour defined elsewhere"),
    (
        "LONGHOLE",
        "its elongated holes are as wide as the tool, whose diameter the dry run does not know",
    ),
    (
        "CYCLE79",
        "its parameter order (multi-edge spigot) is not known here",
    ),
    (
        "CYCLE899",
        "its parameter order (open slot) is not known here",
    ),
];

/// Drilling cycles, `CYCLE8x(RTP, RFP, SDIS, DP, DPR, …)`: a hole where the tool stands, from the
/// reference plane down to the final depth (its radius is the tool's, which the probe margin covers).
const DRILLS: &[&str] = &[
    "CYCLE81", "CYCLE82", "CYCLE83", "CYCLE84", "CYCLE840", "CYCLE85", "CYCLE86", "CYCLE87",
    "CYCLE88", "CYCLE89",
];

/// The depth range a drilling cycle's `RFP`, `DP` and `DPR` give.
fn drilled_depth(args: &[Arg]) -> Result<[f64; 2], String> {
    depth(&Args(args), 1, 3, Some(4), false)
}

/// A hole drilled at `at` over `depth`, as a box of no width.
fn hole(at: [f64; 2], depth: [f64; 2]) -> Region {
    Region {
        plane: [[at[0], at[0]], [at[1], at[1]]],
        depth,
        island: None,
    }
}

type Shape = fn(&Args) -> Result<Region, String>;

/// Milling cycles whose region their arguments give.
const SHAPES: &[(&str, Shape)] = &[
    ("CYCLE61", face_cycle61),
    ("CYCLE71", face_cycle71),
    ("POCKET1", pocket1),
    ("POCKET2", pocket2),
    ("POCKET3", pocket3),
    ("POCKET4", pocket4),
    ("CYCLE76", spigot_cycle76),
    ("CYCLE77", spigot_cycle77),
    ("SLOT1", slot1),
    ("SLOT2", slot2),
];

/// A call's arguments, read by position.
struct Args<'a>(&'a [Arg]);

impl Args<'_> {
    /// Argument `k` (0-based), `what` in messages, which the shape needs.
    fn num(&self, k: usize, what: &str) -> Result<f64, String> {
        self.opt(k, what)?
            .ok_or_else(|| format!("its parameter {} ({what}) is not given", k + 1))
    }

    /// Argument `k`, which may be left out; one the dry run cannot evaluate is an error all the same.
    fn opt(&self, k: usize, what: &str) -> Result<Option<f64>, String> {
        match self.0.get(k) {
            Some(Arg::Num(v)) if v.is_finite() => Ok(Some(*v)),
            None | Some(Arg::Omitted) => Ok(None),
            Some(_) => Err(format!(
                "its parameter {} ({what}) is a value the dry run cannot evaluate",
                k + 1
            )),
        }
    }

    /// Arguments `k` and `k + 1`: a point in the working plane (`_PA`, `_PO`, …), `what` in messages.
    fn point(&self, k: usize, what: &str) -> Result<[f64; 2], String> {
        Ok([
            self.num(k, &format!("{what}, first axis"))?,
            self.num(k + 1, &format!("{what}, second axis"))?,
        ])
    }

    /// Argument `k` as a length or radius: positive (the manuals enter them without sign).
    fn size(&self, k: usize, what: &str) -> Result<f64, String> {
        let v = self.num(k, what)?.abs();
        if v > 0.0 {
            Ok(v)
        } else {
            Err(format!("its parameter {} ({what}) is 0", k + 1))
        }
    }

    /// Whether the call has more arguments than the cycle's classic form: the longer SINUMERIK Operate
    /// form, whose mode parameters (`_AMODE`: absolute or incremental values; the reference point of a
    /// pocket) were not verified here, so the region covers every reading of them.
    fn longer_than(&self, classic: usize) -> bool {
        self.0.len() > classic
    }
}

/// The tool-axis range from the deepest point reached to the reference plane (argument `rfp`). `dp`: the
/// final depth, absolute — in the longer Operate form absolute or relative to the reference plane
/// (`dp_may_be_relative`: both are taken). `dpr`: a depth relative to the reference plane, without sign.
/// Where both a `dp` and a `dpr` are given, the cycle uses one of them (the manuals say which: as recalled,
/// the relative one, not verified here): the deeper of the two covers either.
fn depth(
    a: &Args,
    rfp: usize,
    dp: usize,
    dpr: Option<usize>,
    dp_may_be_relative: bool,
) -> Result<[f64; 2], String> {
    let top = a.num(rfp, "reference plane")?;
    let mut bottoms = Vec::new();
    if let Some(v) = a.opt(dp, "final depth")? {
        bottoms.push(v);
        if dp_may_be_relative {
            bottoms.push(top - v.abs());
        }
    }
    if let Some(k) = dpr
        && let Some(v) = a.opt(k, "depth relative to the reference plane")?
    {
        bottoms.push(top - v.abs());
    }
    let bottom = bottoms
        .into_iter()
        .reduce(f64::min)
        .ok_or_else(|| format!("its depth (parameter {}) is not given", dp + 1))?;
    Ok([bottom.min(top), top])
}

/// The smallest range holding `values`.
fn hull(values: &[f64]) -> [f64; 2] {
    values
        .iter()
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| {
            [lo.min(*v), hi.max(*v)]
        })
}

/// The box holding the rectangle `[lo, hi]` (relative to `at`) turned by `degrees` about `at`.
fn turned_box(at: [f64; 2], lo: [f64; 2], hi: [f64; 2], degrees: f64) -> [[f64; 2]; 2] {
    let (s, c) = degrees.to_radians().sin_cos();
    let corners = [
        [lo[0], lo[1]],
        [hi[0], lo[1]],
        [hi[0], hi[1]],
        [lo[0], hi[1]],
    ];
    let turned = corners.map(|[x, y]| [at[0] + c * x - s * y, at[1] + s * x + c * y]);
    [hull(&turned.map(|p| p[0])), hull(&turned.map(|p| p[1]))]
}

/// The box holding a circle (or a ring's outside) of `radius` about `at`.
fn around(at: [f64; 2], radius: f64) -> [[f64; 2]; 2] {
    [
        [at[0] - radius, at[0] + radius],
        [at[1] - radius, at[1] + radius],
    ]
}

/// Face milling, SINUMERIK Operate: `CYCLE61(_RTP, _RFP, _SDIS, _DP, X0, Y0, X1, Y1, …)` — the rectangle
/// from corner X0/Y0 to corner X1/Y1 (absolute or relative to X0/Y0: both), down to Z1 (`_DP`).
fn face_cycle61(a: &Args) -> Result<Region, String> {
    let (x0, y0) = (a.num(4, "corner X0")?, a.num(5, "corner Y0")?);
    let (x1, y1) = (a.num(6, "corner X1")?, a.num(7, "corner Y1")?);
    Ok(Region {
        plane: [hull(&[x0, x1, x0 + x1]), hull(&[y0, y1, y0 + y1])],
        depth: depth(a, 1, 3, None, true)?,
        island: None,
    })
}

/// Face milling: `CYCLE71(_RTP, _RFP, _SDIS, _DP, _PA, _PO, _LENG, _WID, _STA, …)` — from the starting
/// point `_PA`/`_PO` a rectangle `_LENG` × `_WID` (signed: the corner it starts from), turned by `_STA`.
fn face_cycle71(a: &Args) -> Result<Region, String> {
    let at = a.point(4, "starting point")?;
    let (l, w) = (a.num(6, "length _LENG")?, a.num(7, "width _WID")?);
    if l == 0.0 || w == 0.0 {
        return Err("its rectangle (parameters 7 and 8) has no area".into());
    }
    let sta = a.opt(8, "angle _STA")?.unwrap_or(0.0);
    Ok(Region {
        plane: turned_box(at, [l.min(0.0), w.min(0.0)], [l.max(0.0), w.max(0.0)], sta),
        depth: depth(a, 1, 3, None, false)?,
        island: None,
    })
}

/// A rectangle `l` × `w` about its centre `at` turned by `sta` degrees.
fn centred_rectangle(at: [f64; 2], l: f64, w: f64, sta: f64) -> [[f64; 2]; 2] {
    turned_box(at, [-l / 2.0, -w / 2.0], [l / 2.0, w / 2.0], sta)
}

/// `POCKET1(_RTP, _RFP, _SDIS, _DP, _DPR, _LENG, _WID, _CRAD, _CPA, _CPO, _STA1, …)`: centred at
/// `_CPA`/`_CPO`.
fn pocket1(a: &Args) -> Result<Region, String> {
    let at = a.point(8, "centre")?;
    let (l, w) = (a.size(5, "length _LENG")?, a.size(6, "width _WID")?);
    let sta = a.opt(10, "angle _STA1")?.unwrap_or(0.0);
    Ok(Region {
        plane: centred_rectangle(at, l, w, sta),
        depth: depth(a, 1, 3, Some(4), false)?,
        island: None,
    })
}

/// `POCKET2(_RTP, _RFP, _SDIS, _DP, _DPR, _PRAD, _CPA, _CPO, …)`: a circle about `_CPA`/`_CPO`.
fn pocket2(a: &Args) -> Result<Region, String> {
    let at = a.point(6, "centre")?;
    Ok(Region {
        plane: around(at, a.size(5, "radius _PRAD")?),
        depth: depth(a, 1, 3, Some(4), false)?,
        island: None,
    })
}

/// `POCKET3(_RTP, _RFP, _SDIS, _DP, _LENG, _WID, _CRAD, _PA, _PO, _STA, _MID, _FAL, _FALD, _FFP1, _FFD,
/// _CDIR, _VARI, _MIDA, _AP1, _AP2, _AD, _RAD1, _DP1)`: centred at `_PA`/`_PO`. The longer Operate form
/// may place the reference point at a corner: the box then covers the rectangle on every side of it.
fn pocket3(a: &Args) -> Result<Region, String> {
    let at = a.point(7, "reference point")?;
    let (l, w) = (a.size(4, "length _LENG")?, a.size(5, "width _WID")?);
    let sta = a.opt(9, "angle _STA")?.unwrap_or(0.0);
    let longer = a.longer_than(23);
    let plane = if longer {
        turned_box(at, [-l, -w], [l, w], sta)
    } else {
        centred_rectangle(at, l, w, sta)
    };
    Ok(Region {
        plane,
        depth: depth(a, 1, 3, None, longer)?,
        island: None,
    })
}

/// `POCKET4(_RTP, _RFP, _SDIS, _DP, _PRAD, _PA, _PO, _MID, _FAL, _FALD, _FFP1, _FFD, _CDIR, _VARI, _MIDA,
/// _AP1, _AD, _RAD1, _DP1)`: a circle about `_PA`/`_PO`.
fn pocket4(a: &Args) -> Result<Region, String> {
    let at = a.point(5, "centre")?;
    Ok(Region {
        plane: around(at, a.size(4, "radius _PRAD")?),
        depth: depth(a, 1, 3, None, a.longer_than(19))?,
        island: None,
    })
}

/// `CYCLE76(_RTP, _RFP, _SDIS, _DP, _DPR, _LENG, _WID, _CRAD, _PA, _PO, _STA, _MID, _FAL, _FALD, _FFP1,
/// _FFD, _CDIR, _VARI, _AP1, _AP2)`: the blank `_AP1` × `_AP2` about the spigot's centre `_PA`/`_PO`
/// milled down, the spigot `_LENG` × `_WID` left standing.
fn spigot_cycle76(a: &Args) -> Result<Region, String> {
    let at = a.point(8, "centre")?;
    let (l, w) = (a.size(5, "length _LENG")?, a.size(6, "width _WID")?);
    let (bl, bw) = (
        a.size(18, "blank length _AP1")?,
        a.size(19, "blank width _AP2")?,
    );
    if bl < l || bw < w {
        return Err("its blank (parameters 19, 20) is smaller than the spigot".into());
    }
    let sta = a.opt(10, "angle _STA")?.unwrap_or(0.0);
    Ok(Region {
        plane: centred_rectangle(at, bl, bw, sta),
        depth: depth(a, 1, 3, Some(4), a.longer_than(20))?,
        // A turned spigot holds no box this simple reading could name: none is left out.
        island: (sta.rem_euclid(180.0) == 0.0).then(|| centred_rectangle(at, l, w, 0.0)),
    })
}

/// `CYCLE77(_RTP, _RFP, _SDIS, _DP, _DPR, _PRAD, _PA, _PO, _MID, _FAL, _FALD, _FFP1, _FFD, _CDIR, _VARI,
/// _AP1)`: the blank of diameter `_AP1` about `_PA`/`_PO` milled down, the spigot of radius `_PRAD` left
/// standing (the square inside it).
fn spigot_cycle77(a: &Args) -> Result<Region, String> {
    let at = a.point(6, "centre")?;
    let radius = a.size(5, "radius _PRAD")?;
    let blank = a.size(15, "blank diameter _AP1")? / 2.0;
    if blank < radius {
        return Err("its blank (parameter 16) is smaller than the spigot".into());
    }
    Ok(Region {
        plane: around(at, blank),
        depth: depth(a, 1, 3, Some(4), a.longer_than(16))?,
        island: Some(around(at, radius / std::f64::consts::SQRT_2)),
    })
}

/// Slots on the circle `radius` about `at` that reach `reach` beyond it either way: the ring's box, with
/// the square inside the ring's inside left out.
fn ring(at: [f64; 2], radius: f64, reach: f64) -> [[[f64; 2]; 2]; 2] {
    let inside = (radius - reach).max(0.0) / std::f64::consts::SQRT_2;
    [around(at, radius + reach), around(at, inside)]
}

/// `SLOT1(_RTP, _RFP, _SDIS, _DP, _DPR, _NUM, _LENG, _WID, _CPA, _CPO, _RAD, _STA1, _INDA, …)`: `_NUM`
/// slots `_LENG` × `_WID` on the circle `_RAD` about `_CPA`/`_CPO`; wherever on the slot the circle runs,
/// it stays within length plus width of it.
fn slot1(a: &Args) -> Result<Region, String> {
    let at = a.point(8, "circle centre")?;
    let (l, w) = (a.size(6, "length _LENG")?, a.size(7, "width _WID")?);
    let [outer, inner] = ring(at, a.num(10, "circle radius _RAD")?.abs(), l + w);
    Ok(Region {
        plane: outer,
        depth: depth(a, 1, 3, Some(4), false)?,
        island: Some(inner),
    })
}

/// `SLOT2(_RTP, _RFP, _SDIS, _DP, _DPR, _NUM, _AFSL, _WID, _CPA, _CPO, _RAD, _STA1, _INDA, …)`: `_NUM`
/// circumferential slots `_WID` wide along the circle `_RAD` about `_CPA`/`_CPO`.
fn slot2(a: &Args) -> Result<Region, String> {
    let at = a.point(8, "circle centre")?;
    let w = a.size(7, "width _WID")?;
    let [outer, inner] = ring(at, a.num(10, "circle radius _RAD")?.abs(), w);
    Ok(Region {
        plane: outer,
        depth: depth(a, 1, 3, Some(4), false)?,
        island: Some(inner),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(values: &[Option<f64>]) -> Vec<Arg> {
        values
            .iter()
            .map(|v| v.map_or(Arg::Omitted, Arg::Num))
            .collect()
    }

    fn known(name: &str, values: &[Option<f64>]) -> Region {
        match extent(name, &args(values), false, [0.0, 0.0]) {
            Some(Extent::Known(r)) => r,
            other => panic!("{name}: {other:?}"),
        }
    }

    #[test]
    fn a_face_cycle61_covers_its_corners_read_either_way() {
        // The shop9 call: X-10…130, Y-10…90 from Z1 down to Z0.
        let r = known(
            "CYCLE61",
            &[
                50., 1., 2., 0., -10., -10., 130., 90., 3., 40., 0.2, 1000., 31., 0., 1., 10100.,
            ]
            .map(Some),
        );
        assert_eq!(r.plane, [[-10.0, 130.0], [-10.0, 90.0]]);
        assert_eq!(r.depth, [0.0, 1.0]);
    }

    #[test]
    fn a_turned_pocket_is_held_by_its_enclosing_box() {
        let mut v = [None; 23];
        for (k, x) in [
            (0, 50.),
            (1, 0.),
            (2, 1.),
            (3, -8.),
            (4, 40.),
            (5, 10.),
            (7, 20.),
            (8, 20.),
            (9, 90.),
        ] {
            v[k] = Some(x);
        }
        let r = known("POCKET3", &v);
        assert!(near(r.plane, [[15.0, 25.0], [0.0, 40.0]]), "{r:?}");
        assert_eq!(r.depth, [-8.0, 0.0]);
    }

    #[test]
    fn the_deeper_of_an_absolute_and_a_relative_depth_is_taken() {
        let mut v = [None; 16];
        for (k, x) in [
            (1, 0.),
            (3, -2.),
            (4, 5.),
            (5, 10.),
            (6, 20.),
            (7, 30.),
            (15, 40.),
        ] {
            v[k] = Some(x);
        }
        assert_eq!(known("CYCLE77", &v).depth, [-5.0, 0.0]);
        v[4] = None;
        assert_eq!(known("CYCLE77", &v).depth, [-2.0, 0.0]);
    }

    #[test]
    fn what_the_arguments_do_not_give_is_unknown() {
        let mut a = args(&[50., 1., 2., 0., -10., -10., 130., 90.].map(Some));
        a[6] = Arg::Unknown;
        assert_eq!(
            extent("CYCLE61", &a, false, [0.0, 0.0]),
            Some(Extent::Unknown(
                "its parameter 7 (corner X1) is a value the dry run cannot evaluate".into()
            ))
        );
        assert!(matches!(
            extent("CYCLE72", &[], false, [0.0, 0.0]),
            Some(Extent::Unknown(_))
        ));
        assert!(matches!(
            extent("POCKET4", &args(&[Some(50.), Some(0.)]), false, [0.0, 0.0]),
            Some(Extent::Unknown(_))
        ));
        assert!(matches!(
            extent(
                "POCKET4",
                &args(&[50., 0., 1., -5., 10., 0., 0.].map(Some)),
                true,
                [0.0, 0.0]
            ),
            Some(Extent::Unknown(_))
        ));
        assert_eq!(extent("L100", &[], false, [0.0, 0.0]), None);
    }

    fn near(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> bool {
        (0..4).all(|k| (a[k / 2][k % 2] - b[k / 2][k % 2]).abs() < 1e-9)
    }

    #[test]
    fn a_hole_pattern_takes_the_depth_of_the_modal_drilling_cycle() {
        let drill = (
            "CYCLE81".to_string(),
            args(&[Some(50.), Some(0.), Some(2.), Some(-6.)]),
        );
        let holes = |name: &str, values: &[Option<f64>]| -> Vec<[f64; 2]> {
            match pattern_extent(name, &args(values), [5.0, 5.0], Some(&drill)) {
                Some(Extent::Holes(holes)) => holes
                    .iter()
                    .map(|h| {
                        assert_eq!(h.depth, [-6.0, 0.0]);
                        assert_eq!(h.plane.map(|r| r[0]), h.plane.map(|r| r[1]));
                        [h.plane[0][0], h.plane[1][0]]
                    })
                    .collect(),
                other => panic!("{name}: {other:?}"),
            }
        };
        let close = |a: &[[f64; 2]], b: &[[f64; 2]]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(p, q)| (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9)
        };
        let row = holes("HOLES1", &[10., 10., 90., 5., 20., 3.].map(Some));
        assert!(
            close(&row, &[[10., 15.], [10., 35.], [10., 55.]]),
            "{row:?}"
        );
        // INDA 0: the full circle divided by the number of holes, from the start angle.
        let circle = holes("HOLES2", &[0., 0., 10., 90., 0., 2.].map(Some));
        assert!(close(&circle, &[[0., 10.], [0., -10.]]), "{circle:?}");
        let grid = holes("CYCLE801", &[0., 0., 0., 10., 5., 2., 2.].map(Some));
        assert!(
            close(&grid, &[[0., 0.], [10., 0.], [0., 5.], [10., 5.]]),
            "{grid:?}"
        );
        // Free positions: absolute under masks of ones, else also steps from X5 Y5.
        let mut free = [None; 23];
        free[2..6].copy_from_slice(&[Some(10.), Some(0.), Some(10.), Some(0.)]);
        free[..2].copy_from_slice(&[Some(111111111.); 2]);
        assert!(close(&holes("CYCLE802", &free), &[[10., 0.], [10., 0.]]));
        free[0] = Some(101111111.);
        let both = holes("CYCLE802", &free);
        assert!(
            close(&both, &[[10., 0.], [15., 5.], [10., 0.], [25., 5.]]),
            "{both:?}"
        );
        // No modal call: the pattern only positions; a count that is none is unknown.
        assert_eq!(
            pattern_extent("HOLES1", &args(&[Some(0.); 6]), [0.0, 0.0], None),
            None
        );
        assert!(matches!(
            pattern_extent(
                "HOLES2",
                &args(&[0., 0., 10., 0., 0., 2.5].map(Some)),
                [0.0, 0.0],
                Some(&drill)
            ),
            Some(Extent::Unknown(_))
        ));
        assert_eq!(
            pattern_extent("CYCLE81", &[], [0.0, 0.0], Some(&drill)),
            None
        );
    }

    #[test]
    fn a_drilling_cycle_drills_where_the_tool_stands() {
        // `MCALL CYCLE83(50, 0, 2, , 12)` after `X12 Y34`: DPR 12 below the reference plane.
        let a = args(&[Some(50.), Some(0.), Some(2.), None, Some(12.)]);
        let Some(Extent::Known(r)) = extent("CYCLE83", &a, true, [12.0, 34.0]) else {
            panic!("no region");
        };
        assert_eq!(r.plane, [[12.0, 12.0], [34.0, 34.0]]);
        assert_eq!(r.depth, [-12.0, 0.0]);
        assert!(matches!(
            extent("CYCLE81", &args(&[Some(50.), Some(0.)]), true, [0.0, 0.0]),
            Some(Extent::Unknown(_))
        ));
    }
}
