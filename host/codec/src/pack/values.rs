//! One attribute's values in a packed mesh: each element predicted from elements decoded
//! before it, the residual of every component coded exactly.
//!
//! Elements come in the order the decoder meets them: vertices in the geometry's coding
//! order (a front grown over the surface, so consecutive vertices are neighbours), faces and
//! corners in triangle order. Residuals are exact, in the numbers' images
//! ([`numbers`](crate::correction::coding::numbers)).
//!
//! The predictors ([`Predictor`]), one per attribute, chosen by the encoder as the one whose
//! residuals are smallest on a sample of the elements ([`choose`]):
//! - the previous element in that order;
//! - the mean of the decoded neighbours: a vertex's neighbours coded before it, a face's
//!   earlier faces across an edge, a corner's last earlier corner at the same vertex (on a
//!   texture chart it is the same value) or else the earlier corners of its triangle;
//! - a vertex's parallelogram rules, as for positions (linear gradients: colour ramps,
//!   texture coordinates);
//! - for three-number float vertex attributes, the normal of the decoded geometry:
//!   area-weighted, summed in triangle order as the store recomputes normals, so a normal the
//!   store computed is predicted to the bit; or angle-weighted, what Blender writes (half its
//!   normals on the CAD parts measured were predicted to within 0.001°), with a
//!   deterministic arctangent;
//! - zero.
//!
//! Each component after the first may also add the previous component's residual to its
//! prediction (colour channels brighten and darken together), and any component may name one
//! of its 32 recent values instead (a palette, a texture atlas's repeated coordinates, a
//! flat-shaded normal); the encoder keeps each where it makes the estimate smaller.

use meshflow_mesh::attributes::Domain;
use meshflow_topology::VertexTriangles;

use crate::correction::coding::numbers::{
    Costs, MAX_COMPONENTS, MISS, Number, RECENT_VALUES, Recent, ValueModels, adjusted, difference,
    zigzag,
};
use crate::correction::coding::stream::{CorruptStream, SymbolReader, SymbolWriter};

/// What predicts an element's values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Predictor {
    Zero = 0,
    Previous = 1,
    Neighbours = 2,
    /// The decoded geometry's normal (three-number float vertex attributes).
    Normal = 3,
    /// The parallelogram rules of a vertex's triangles (as for positions), else
    /// [`Neighbours`](Self::Neighbours): follows linear gradients.
    Parallelogram = 4,
    /// The decoded geometry's angle-weighted normal, what Blender and many tools write.
    AngleNormal = 5,
}

impl Predictor {
    pub(super) fn from_byte(b: u8) -> Option<Self> {
        [
            Self::Zero,
            Self::Previous,
            Self::Neighbours,
            Self::Normal,
            Self::Parallelogram,
            Self::AngleNormal,
        ]
        .get(usize::from(b))
        .copied()
    }

    /// The predictors worth trying for an attribute.
    pub(crate) fn candidates(domain: Domain, components: usize, float: bool) -> Vec<Self> {
        let mut list = vec![Self::Neighbours, Self::Previous, Self::Zero];
        if domain == Domain::Vertex {
            list.insert(0, Self::Parallelogram);
        }
        if domain == Domain::Vertex && components == 3 && float {
            list.splice(0..0, [Self::Normal, Self::AngleNormal]);
        }
        list
    }

    /// Whether the decoder can use it for an attribute of this shape.
    pub(crate) fn fits(self, domain: Domain, components: usize, float: bool) -> bool {
        match self {
            Self::Normal | Self::AngleNormal => {
                domain == Domain::Vertex && components == 3 && float
            }
            Self::Parallelogram => domain == Domain::Vertex,
            _ => true,
        }
    }
}

/// The decoded mesh, as attribute prediction sees it.
pub(crate) struct Geometry<'a> {
    pub(super) positions: &'a [f32],
    pub(super) triangles: &'a [u32],
    pub(super) around: &'a VertexTriangles,
    /// Every vertex once, in the geometry's coding order.
    pub(super) order: &'a [u32],
    /// Each vertex's place in `order`.
    pub(super) rank: Vec<u32>,
}

impl<'a> Geometry<'a> {
    pub(crate) fn new(
        positions: &'a [f32],
        triangles: &'a [u32],
        around: &'a VertexTriangles,
        order: &'a [u32],
    ) -> Self {
        let mut rank = vec![0u32; order.len()];
        for (i, &v) in order.iter().enumerate() {
            rank[v as usize] = i as u32;
        }
        Self { positions, triangles, around, order, rank }
    }

    /// The triangles around `a` or around `b`, whichever are fewer: where to look for the
    /// triangles on edge `a b`.
    fn shorter(&self, a: u32, b: u32) -> &[u32] {
        let (around_a, around_b) = (self.around.of(a), self.around.of(b));
        if around_a.len() <= around_b.len() { around_a } else { around_b }
    }

    /// Elements of `domain`.
    pub(super) fn count(&self, domain: Domain) -> usize {
        domain.len(self.order.len(), self.triangles.len() / 3)
    }

    /// The `i`th element of `domain` in coding order.
    fn element(&self, domain: Domain, i: usize) -> usize {
        match domain {
            Domain::Vertex => self.order[i] as usize,
            Domain::Face | Domain::Corner => i,
        }
    }

    /// Per vertex, the sum of its triangles' cross products (area-weighted normal),
    /// degenerate triangles left out, in triangle order: the store's recomputation; or with
    /// `by_angle`, of their unit normals times the corner's angle.
    fn normal_sums(&self, by_angle: bool) -> Vec<[f64; 3]> {
        let p = |v: u32| {
            let i = 3 * v as usize;
            [self.positions[i], self.positions[i + 1], self.positions[i + 2]].map(f64::from)
        };
        let mut sums = vec![[0.0f64; 3]; self.order.len()];
        for c in self.triangles.chunks_exact(3) {
            let [a, b, d] = [c[0], c[1], c[2]];
            if a == b || b == d || a == d {
                continue;
            }
            let (pa, pb, pd) = (p(a), p(b), p(d));
            let n = cross(sub(pb, pa), sub(pd, pa));
            if !by_angle {
                for v in [a, b, d] {
                    let s = &mut sums[v as usize];
                    (0..3).for_each(|k| s[k] += n[k]);
                }
                continue;
            }
            let length = dot(n, n).sqrt();
            if length == 0.0 {
                continue;
            }
            for (v, pv, x, y) in [(a, pa, pb, pd), (b, pb, pd, pa), (d, pd, pa, pb)] {
                let (e1, e2) = (sub(x, pv), sub(y, pv));
                let angle = atan2(dot(cross(e1, e2), cross(e1, e2)).sqrt(), dot(e1, e2));
                let s = &mut sums[v as usize];
                (0..3).for_each(|k| s[k] += angle * n[k] / length);
            }
        }
        sums
    }
}

/// Predicts the elements of one attribute in coding order; both sides call
/// [`next`](Self::next) once per element, in order, after the earlier ones are known.
pub(crate) struct Predictions<'g, 'a> {
    geometry: &'g Geometry<'a>,
    domain: Domain,
    predictor: Predictor,
    components: usize,
    /// Per vertex, the normal sums, for [`Predictor::Normal`].
    normals: Vec<[f64; 3]>,
    /// Per vertex, 1 + the last corner at it so far (0: none), for corner neighbours.
    last_corner: Vec<u32>,
    sources: Vec<usize>,
    position: usize,
}

impl<'g, 'a> Predictions<'g, 'a> {
    pub(crate) fn new(
        geometry: &'g Geometry<'a>,
        domain: Domain,
        predictor: Predictor,
        components: usize,
    ) -> Self {
        let normals = match predictor {
            Predictor::Normal => geometry.normal_sums(false),
            Predictor::AngleNormal => geometry.normal_sums(true),
            _ => Vec::new(),
        };
        let last_corner = if domain == Domain::Corner && predictor == Predictor::Neighbours {
            vec![0; geometry.order.len()]
        } else {
            Vec::new()
        };
        Self {
            geometry,
            domain,
            predictor,
            components,
            normals,
            last_corner,
            sources: Vec::new(),
            position: 0,
        }
    }

    /// The element the next call predicts.
    pub(super) fn element(&self) -> usize {
        self.geometry.element(self.domain, self.position)
    }

    /// The predicted images of the next element's components, reading only elements that
    /// came before it in `values`.
    pub(super) fn next<T: Number>(&mut self, values: &[T]) -> [u64; MAX_COMPONENTS] {
        let i = self.position;
        self.position += 1;
        self.at(values, i)
    }

    /// Whether [`at`](Self::at) may skip positions: all but corners by their neighbours,
    /// which remember the corners met so far.
    pub(crate) fn random_access(&self) -> bool {
        !(self.domain == Domain::Corner && self.predictor == Predictor::Neighbours)
    }

    /// The prediction for the `i`th element in coding order, all before it known.
    pub(crate) fn at<T: Number>(&mut self, values: &[T], i: usize) -> [u64; MAX_COMPONENTS] {
        let (g, domain, n) = (self.geometry, self.domain, self.components);
        let e = g.element(domain, i);
        let copy = |s: usize| -> [u64; MAX_COMPONENTS] {
            std::array::from_fn(|k| if k < n { values[n * s + k].image() } else { 0 })
        };
        let previous = || if i == 0 { [0; MAX_COMPONENTS] } else { copy(g.element(domain, i - 1)) };
        match self.predictor {
            Predictor::Zero => [0; MAX_COMPONENTS],
            Predictor::Previous => previous(),
            Predictor::Normal | Predictor::AngleNormal => {
                let s = self.normals[e];
                let length = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
                if length > 0.0 {
                    return std::array::from_fn(|k| {
                        if k < 3 { T::nearest_image(s[k] / length) } else { 0 }
                    });
                }
                self.sources.clear();
                self.vertex_sources(e);
                self.mean(values, previous())
            }
            Predictor::Parallelogram => {
                if let Some(p) = self.parallelogram(values, e) {
                    return p;
                }
                self.sources.clear();
                self.vertex_sources(e);
                self.mean(values, previous())
            }
            Predictor::Neighbours => {
                self.sources.clear();
                match self.domain {
                    Domain::Vertex => self.vertex_sources(e),
                    Domain::Face => self.face_sources(e),
                    Domain::Corner => self.corner_sources(e),
                }
                self.mean(values, previous())
            }
        }
    }

    fn mean<T: Number>(
        &self,
        values: &[T],
        otherwise: [u64; MAX_COMPONENTS],
    ) -> [u64; MAX_COMPONENTS] {
        let n = self.components;
        match self.sources[..] {
            [] => otherwise,
            // One source is copied: exact, `-0.0` included.
            [s] => std::array::from_fn(|k| if k < n { values[n * s + k].image() } else { 0 }),
            _ => std::array::from_fn(|k| {
                if k >= n {
                    return 0;
                }
                let sum: f64 = self.sources.iter().map(|&s| values[n * s + k].value()).sum();
                T::nearest_image(sum / self.sources.len() as f64)
            }),
        }
    }

    /// The mean of `a + b - o` over vertex `v`'s triangles `(v, a, b)` whose edge `a b` has
    /// an opposite triangle `(b, a, o)` with all three coded before `v`.
    fn parallelogram<T: Number>(&self, values: &[T], v: usize) -> Option<[u64; MAX_COMPONENTS]> {
        let g = self.geometry;
        let n = self.components;
        let rank = g.rank[v];
        let known = |u: u32| g.rank[u as usize] < rank;
        let corners = |t: u32| {
            let i = 3 * t as usize;
            [g.triangles[i], g.triangles[i + 1], g.triangles[i + 2]]
        };
        let mut sums = [0.0f64; MAX_COMPONENTS];
        let mut rules = 0u32;
        for &t in g.around.of(v as u32) {
            let c = corners(t);
            let Some(k) = c.iter().position(|&x| x as usize == v) else { continue };
            let (a, b) = (c[(k + 1) % 3], c[(k + 2) % 3]);
            if a == b || !known(a) || !known(b) {
                continue;
            }
            let opposite = g.shorter(a, b).iter().take(SCAN).filter(|&&u| u != t).find_map(|&u| {
                let d = corners(u);
                let third = d.iter().copied().find(|&x| x != a && x != b)?;
                (d.contains(&a) && d.contains(&b) && known(third)).then_some(third)
            });
            if let Some(o) = opposite {
                let at = |x: u32, k: usize| values[n * x as usize + k].value();
                (0..n).for_each(|k| sums[k] += at(a, k) + at(b, k) - at(o, k));
                rules += 1;
            }
        }
        (rules > 0).then(|| {
            std::array::from_fn(|k| {
                if k < n { T::nearest_image(sums[k] / f64::from(rules)) } else { 0 }
            })
        })
    }

    /// The neighbours of vertex `v` coded before it, once per triangle they share.
    fn vertex_sources(&mut self, v: usize) {
        let g = self.geometry;
        let rank = g.rank[v];
        for &t in g.around.of(v as u32) {
            let c = &g.triangles[3 * t as usize..3 * t as usize + 3];
            for &u in c {
                if u as usize != v && g.rank[u as usize] < rank {
                    self.sources.push(u as usize);
                }
            }
        }
    }

    /// The earlier triangles sharing an edge with triangle `t`.
    fn face_sources(&mut self, t: usize) {
        let g = self.geometry;
        let c = &g.triangles[3 * t..3 * t + 3];
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            if a == b {
                continue;
            }
            for &s in g.shorter(a, b).iter().take(SCAN) {
                if s as usize >= t {
                    break; // ascending
                }
                let d = &g.triangles[3 * s as usize..3 * s as usize + 3];
                if d.contains(&a) && d.contains(&b) && !self.sources.contains(&(s as usize)) {
                    self.sources.push(s as usize);
                }
            }
        }
    }

    /// Corner `c`'s last earlier corner at the same vertex, else its triangle's earlier
    /// corners.
    fn corner_sources(&mut self, c: usize) {
        let v = self.geometry.triangles[c] as usize;
        match self.last_corner[v] {
            0 => self.sources.extend(3 * (c / 3)..c),
            last => self.sources.push(last as usize - 1),
        }
        self.last_corner[v] = c as u32 + 1;
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(u: [f64; 3], w: [f64; 3]) -> [f64; 3] {
    [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
}

fn dot(u: [f64; 3], w: [f64; 3]) -> f64 {
    u[0] * w[0] + u[1] * w[1] + u[2] * w[2]
}

/// The angle of `(x, y)` for `y >= 0`, in `[0, π]`, from `+`, `-`, `*`, `/` alone: every
/// host computes the same bits (a system `atan2` may round differently), and the
/// prediction must be the same on both sides.
fn atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    if x > 0.0 {
        atan(y / x)
    } else if x < 0.0 {
        PI - atan(y / -x)
    } else {
        FRAC_PI_2
    }
}

/// Arctangent for `x >= 0` (Cephes' reduction and rational approximation, within an ulp
/// or two of the true value).
#[allow(clippy::excessive_precision)] // Cephes' coefficients as published
fn atan(x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    const P: [f64; 5] = [
        -8.750608600031904122785e-1,
        -1.615753718733365076637e1,
        -7.500855792314704667340e1,
        -1.228866684490136173410e2,
        -6.485021904942025371773e1,
    ];
    const Q: [f64; 5] = [
        2.485846490142306297962e1,
        1.650270098316988542046e2,
        4.328810604912902668951e2,
        4.853903996359136964868e2,
        1.945506571482613964425e2,
    ];
    let (offset, z) = if x > 2.414_213_562_373_095 {
        (FRAC_PI_2, -1.0 / x)
    } else if x <= 0.66 {
        (0.0, x)
    } else {
        (FRAC_PI_4, (x - 1.0) / (x + 1.0))
    };
    let zz = z * z;
    let p = P.iter().fold(0.0, |a, &c| a * zz + c);
    let q = Q.iter().fold(1.0, |a, &c| a * zz + c);
    offset + (z * zz * p / q + z)
}

/// Triangles looked at for the ones across an edge, at most: a vertex with a million
/// triangles (a fan a hostile file may hold) costs no more than a few.
const SCAN: usize = 64;
/// Elements the encoder's choice of predictor looks at, at most, in runs of [`RUN`].
const SAMPLE: usize = 1 << 16;
const RUN: usize = 1 << 10;

/// Codes `values` (`components` numbers per element of `domain`).
pub(super) fn write<T: Number>(
    w: &mut SymbolWriter,
    geometry: &Geometry,
    domain: Domain,
    components: usize,
    (predictor, mask): (Predictor, u8),
    values: &[T],
) {
    let mut models = ValueModels::new::<T>(components, mask);
    let mut predictions = Predictions::new(geometry, domain, predictor, components);
    for _ in 0..geometry.count(domain) {
        let e = predictions.element();
        let base = predictions.next(values);
        let mut previous = 0;
        for k in 0..components {
            let actual = values[components * e + k].image();
            models.write::<T>(w, k, actual, adjusted::<T>(base[k], k, mask, previous));
            previous = difference::<T>(actual, base[k]);
        }
    }
}

/// Decodes what [`write`] wrote: `count(domain) × components` numbers.
pub(super) fn read<T: Number>(
    r: &mut SymbolReader,
    geometry: &Geometry,
    domain: Domain,
    components: usize,
    (predictor, mask): (Predictor, u8),
) -> Result<Vec<T>, CorruptStream> {
    let mut models = ValueModels::new::<T>(components, mask);
    let mut predictions = Predictions::new(geometry, domain, predictor, components);
    let mut values = vec![T::default(); geometry.count(domain) * components];
    for _ in 0..geometry.count(domain) {
        let e = predictions.element();
        let base = predictions.next(&values);
        let mut previous = 0;
        for k in 0..components {
            let predicted = adjusted::<T>(base[k], k, mask, previous);
            let actual = models.read::<T>(r, k, predicted)?;
            values[components * e + k] = T::from_image(actual);
            previous = difference::<T>(actual, base[k]);
        }
    }
    Ok(values)
}

/// The positions in coding order the encoder's choice looks at: all of a small attribute,
/// else [`SAMPLE`] of them in runs of [`RUN`] spread over the whole (runs, so that recent
/// values are judged as the coder meets them).
fn sample(count: usize) -> Vec<usize> {
    if count <= SAMPLE {
        return (0..count).collect();
    }
    let runs = SAMPLE / RUN;
    (0..runs).flat_map(|r| (0..RUN).map(move |i| r * (count - RUN) / (runs - 1) + i)).collect()
}

/// Per sampled position and component, the rank of its value among the component's recent
/// values before it in its run, or [`MISS`].
fn recent_ranks<T: Number>(
    geometry: &Geometry,
    domain: Domain,
    components: usize,
    values: &[T],
    sample: &[usize],
) -> Vec<u8> {
    let mut recent: Vec<Recent> = (0..components).map(|_| Recent::default()).collect();
    let mut ranks = Vec::with_capacity(sample.len() * components);
    for (s, &i) in sample.iter().enumerate() {
        if s > 0 && sample[s - 1] + 1 != i {
            recent.iter_mut().for_each(|r| r.0.clear());
        }
        let e = geometry.element(domain, i);
        for (k, recent) in recent.iter_mut().enumerate() {
            let x = values[components * e + k].image();
            ranks.push(recent.find(x).map_or(MISS, |r| r as u8));
            recent.saw(x);
        }
    }
    ranks
}

/// The predictor and mask (recent values, decorrelated components) with the smallest
/// residuals for `values`, judged on a [`sample`] of them.
pub(super) fn choose<T: Number>(
    geometry: &Geometry,
    domain: Domain,
    components: usize,
    float: bool,
    values: &[T],
) -> (Predictor, u8) {
    let count = geometry.count(domain);
    let sample = sample(count);
    let ranks = recent_ranks(geometry, domain, components, values, &sample);
    let n = sample.len() as f64;
    let mut best = (f64::INFINITY, Predictor::Zero, 0u8);
    for predictor in Predictor::candidates(domain, components, float) {
        // Per component: without and with decorrelation.
        let mut costs = [[Costs::default(); 2]; MAX_COMPONENTS];
        let mut predictions = Predictions::new(geometry, domain, predictor, components);
        let mut next = 0; // the next position to predict, for predictors that remember
        for (s, &i) in sample.iter().enumerate() {
            if !predictions.random_access() {
                while next < i {
                    predictions.at(values, next);
                    next += 1;
                }
                next += 1;
            }
            let e = geometry.element(domain, i);
            let base = predictions.at(values, i);
            let mut previous = 0;
            for k in 0..components {
                let actual = values[components * e + k].image();
                let rank = ranks[components * s + k];
                costs[k][0].add(zigzag(difference::<T>(actual, base[k])), rank);
                if k > 0 {
                    let predicted = adjusted::<T>(base[k], k, 1 << k, previous);
                    costs[k][1].add(zigzag(difference::<T>(actual, predicted)), rank);
                }
                previous = difference::<T>(actual, base[k]);
            }
        }
        for recent in [false, true] {
            let price = |c: &Costs| if recent { c.with_recent(n) } else { c.plain() };
            let mut total = 0.0;
            let mut mask = if recent { RECENT_VALUES } else { 0 };
            for (k, [plain, adjusted]) in costs.iter().enumerate().take(components) {
                if k > 0 && price(adjusted) < price(plain) {
                    mask |= 1 << k;
                    total += price(adjusted);
                } else {
                    total += price(plain);
                }
            }
            if total < best.0 {
                best = (total, predictor, mask);
            }
        }
    }
    (best.1, best.2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_is_within_two_ulps_of_the_system_one() {
        for i in 0..200_000 {
            let t = f64::from(i) / 200_000.0;
            let (y, x) = ((7.0 * t).sin().abs() * (1.0 + 40.0 * t), (13.0 * t).cos() * 3.0);
            let (ours, system) = (atan2(y, x), y.atan2(x));
            assert!((ours - system).abs() <= 2.0 * f64::EPSILON * system.abs().max(1.0), "{y} {x}");
        }
        assert_eq!(atan2(0.0, -1.0), std::f64::consts::PI);
        assert_eq!(atan2(1.0, 0.0), std::f64::consts::FRAC_PI_2);
    }
}
