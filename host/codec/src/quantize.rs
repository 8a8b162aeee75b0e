//! Optional grid quantisation: positions snapped to a per-axis grid at ingest, and kept on it
//! after every step.
//!
//! A [`Grid`] has one step per axis, a power of two, so a grid value is an integer multiple
//! of its step: every such multiple is an exact `f32`, snapping is exact and idempotent, and
//! "on the grid" is a property of the bits alone (`0.0` is on every grid, `-0.0` on none, so
//! a grid value has one bit pattern). [`Grid::over`] picks the smallest step that spans the
//! mesh's bounding box in at most `2^bits` cells (at least `2^(bits-1)`), never finer than
//! the `f32` resolution at the box's largest coordinate.
//!
//! Where snapping belongs: plugins compute freely (a smoothing step lands between grid
//! points); the host snaps the step afterwards with [`snap_step`], which replays the step's
//! log with the coordinates it carries snapped, and appends one `set-positions` op only if
//! a computed position (a split's centroid, say) is still off the grid. A step that already
//! ends on the grid is left alone. The store itself stays grid-agnostic; the correction
//! codec detects the grid ([`Grid::detect`]) and codes coordinates as grid steps.
//!
//! ```
//! use meshflow_codec::quantize::Grid;
//! use meshflow_mesh::MeshData;
//! let mut mesh = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.3, 0.0, 0.1, 1.0, 2.0], vec![0, 1, 2]);
//! let grid = Grid::over(&mesh, 4).unwrap();
//! grid.snap_all(&mut mesh.positions);
//! assert!(grid.holds(&mesh.positions));
//! assert_eq!(&mesh.positions[3..6], &[1.0, 0.3125, 0.0]);
//! ```

use meshflow_mesh::MeshData;
use meshflow_mesh::store::{EditError, MeshStore, Op};

/// Grid resolutions `--quantize` accepts, in bits per axis.
pub const BITS: std::ops::RangeInclusive<u32> = 1..=24;

/// Lowest and highest step exponents: the `f32` subnormal unit and a step that still leaves
/// every finite `f32` a nearby grid value.
const MIN_EXPONENT: i32 = -149;
const MAX_EXPONENT: i32 = 127;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum QuantizeError {
    #[error("--quantize {0}: the grid needs {min} to {max} bits per axis", min = BITS.start(), max = BITS.end())]
    Bits(u32),
    #[error("the mesh has a coordinate that is not finite; it cannot be put on a grid")]
    NotFinite,
}

/// A grid per axis: binary (values are integer multiples of `2^exponents[axis]`, what
/// `--quantize` makes) or decimal (values are the `f32`s nearest `index / 10^digits[axis]`,
/// what text formats with a fixed number of decimals give, e.g. OBJ files).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    spacing: Spacing,
}

/// How a [`Grid`]'s values are spaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spacing {
    /// Step exponents per axis: values `index × 2^e`, each an exact `f32`.
    Binary([i32; 3]),
    /// Decimal digits per axis: values `(index / 10^d)` rounded to `f32`.
    Decimal([u8; 3]),
}

/// The most decimal digits a decimal grid has (`10^-12` is below the `f32` resolution of
/// any coordinate above `2^-16`).
pub const MAX_DIGITS: u8 = 12;

impl Grid {
    /// A grid from step exponents, `None` when one is outside `-149..=127`.
    pub fn from_exponents(exponents: [i32; 3]) -> Option<Self> {
        let valid = exponents.iter().all(|e| (MIN_EXPONENT..=MAX_EXPONENT).contains(e));
        valid.then_some(Self { spacing: Spacing::Binary(exponents) })
    }

    /// A decimal grid from digit counts, `None` when one exceeds [`MAX_DIGITS`].
    pub fn from_digits(digits: [u8; 3]) -> Option<Self> {
        digits
            .iter()
            .all(|&d| d <= MAX_DIGITS)
            .then_some(Self { spacing: Spacing::Decimal(digits) })
    }

    pub fn spacing(&self) -> Spacing {
        self.spacing
    }

    /// The step of `axis` (0, 1, 2); a decimal step as the nearest `f64`.
    pub fn step(&self, axis: usize) -> f64 {
        match self.spacing {
            Spacing::Binary(e) => power_of_two(e[axis]),
            Spacing::Decimal(d) => 1.0 / power_of_ten(d[axis]),
        }
    }

    /// The grid index of `x` on `axis`: exact (maybe fractional) on a binary grid, rounded
    /// on a decimal one (check with [`value`](Self::value) whether it gives `x` back).
    pub fn index(&self, axis: usize, x: f32) -> f64 {
        match self.spacing {
            Spacing::Binary(e) => f64::from(x) / power_of_two(e[axis]),
            Spacing::Decimal(d) => (f64::from(x) * power_of_ten(d[axis])).round(),
        }
    }

    /// The grid value of an integer `index` on `axis` (infinite when out of `f32` range).
    pub fn value(&self, axis: usize, index: f64) -> f32 {
        let value = match self.spacing {
            Spacing::Binary(e) => index * power_of_two(e[axis]),
            Spacing::Decimal(d) => index / power_of_ten(d[axis]),
        };
        value as f32 + 0.0
    }

    /// The grid of at most `2^bits` cells per axis over the mesh's bounding box.
    pub fn over(mesh: &MeshData, bits: u32) -> Result<Self, QuantizeError> {
        if !BITS.contains(&bits) {
            return Err(QuantizeError::Bits(bits));
        }
        if mesh.positions.iter().any(|v| !v.is_finite()) {
            return Err(QuantizeError::NotFinite);
        }
        let (lo, hi) = mesh.bounding_box().unwrap_or(([0.0; 3], [0.0; 3]));
        let exponents = std::array::from_fn(|k| {
            let extent = f64::from(hi[k]) - f64::from(lo[k]);
            let largest = lo[k].abs().max(hi[k].abs());
            // Finer than one unit in the last place of the largest value changes nothing.
            let resolution = if largest == 0.0 { MIN_EXPONENT } else { ulp_exponent(largest) };
            let cells = if extent > 0.0 { ceil_log2(extent) - bits as i32 } else { MIN_EXPONENT };
            cells.max(resolution).clamp(MIN_EXPONENT, MAX_EXPONENT)
        });
        Ok(Self { spacing: Spacing::Binary(exponents) })
    }

    /// The coarsest grid every given position lies on, if it is coarser than the `f32`
    /// resolution of the largest coordinate on each axis (so grid indices are cheaper than
    /// float residuals): a binary grid, else a decimal one (one digit count for all axes);
    /// `None` for ordinary float data or a `-0.0`.
    pub fn detect<'a>(position_sets: impl IntoIterator<Item = &'a [f32]> + Clone) -> Option<Self> {
        // Per axis the largest magnitude, whose ulp is the axis' resolution (an ulp grows
        // with the magnitude), in a pass without branches; a -0.0 or a value that is not
        // finite rules out every grid.
        let mut largest = [0u32; 3];
        let mut negative_zero = false;
        for positions in position_sets.clone() {
            for p in positions.chunks_exact(3) {
                for k in 0..3 {
                    let bits = p[k].to_bits();
                    negative_zero |= bits == 0x8000_0000;
                    largest[k] = largest[k].max(bits & 0x7fff_ffff);
                }
            }
        }
        if negative_zero || largest.iter().any(|&m| m >= f32::INFINITY.to_bits()) {
            return None;
        }
        let resolution = largest.map(|m| lowest_bit_and_ulp(m).1);
        // Per axis the lowest set bit's exponent over all values (zeros lie on every grid),
        // until one is at or below its axis' resolution: then no binary grid is coarser,
        // which float data shows at its first values.
        let mut lowest = [i32::MAX; 3];
        'values: for positions in position_sets.clone() {
            for p in positions.chunks_exact(3) {
                for k in 0..3 {
                    let bits = p[k].to_bits();
                    if bits != 0 {
                        lowest[k] = lowest[k].min(lowest_bit_and_ulp(bits).0);
                    }
                }
                if (0..3).any(|k| lowest[k] <= resolution[k]) {
                    break 'values;
                }
            }
        }
        let exponents = std::array::from_fn(|k| match lowest[k] {
            i32::MAX => 0, // only zeros: any grid holds them
            low => low.min(MAX_EXPONENT),
        });
        let coarser = (0..3).all(|k| lowest[k] == i32::MAX || exponents[k] > resolution[k]);
        if coarser {
            return Some(Self { spacing: Spacing::Binary(exponents) });
        }
        // Decimal: the fewest digits that hold every value, while a step is still coarser
        // than the resolution. Float data fails each try at its first value or so.
        let finest = (0..3).map(|k| power_of_two(resolution[k])).fold(0.0, f64::max);
        (1..=MAX_DIGITS)
            .map(|d| Self { spacing: Spacing::Decimal([d; 3]) })
            .take_while(|grid| grid.step(0) > finest)
            .find(|grid| position_sets.clone().into_iter().all(|p| grid.holds(p)))
    }

    /// The grid value nearest `x` on `axis` (ties away from zero on a binary grid); never
    /// `-0.0`. A value too large to round up without overflowing rounds down instead.
    pub fn snap(&self, axis: usize, x: f32) -> f32 {
        let m = self.index(axis, x).round();
        match self.value(axis, m) {
            s if s.is_finite() => s,
            _ => self.value(axis, m - m.signum()),
        }
    }

    pub fn is_on(&self, axis: usize, x: f32) -> bool {
        x.to_bits() == self.snap(axis, x).to_bits()
    }

    /// Whether every position (`x y z` triples) is on the grid.
    pub fn holds(&self, positions: &[f32]) -> bool {
        positions.chunks_exact(3).all(|p| (0..3).all(|k| self.is_on(k, p[k])))
    }

    /// Snaps `x y z` triples in place.
    pub fn snap_all(&self, positions: &mut [f32]) {
        for p in positions.chunks_exact_mut(3) {
            for (k, x) in p.iter_mut().enumerate() {
                *x = self.snap(k, *x);
            }
        }
    }
}

/// Quantises a mesh at ingest: every coordinate snapped to the grid of at most `2^bits`
/// cells per axis over its bounding box. Returns the grid for later [`snap_step`]s.
pub fn quantize(mesh: &mut MeshData, bits: u32) -> Result<Grid, QuantizeError> {
    let grid = Grid::over(mesh, bits)?;
    grid.snap_all(&mut mesh.positions);
    Ok(grid)
}

/// Puts a step's result back on the grid: the coordinates the log carries (added and moved
/// vertices, explicit split points, set positions) are snapped, the log is replayed from
/// `base`, and if a computed position (a centroid, a midpoint, a transform) is still off
/// the grid, one `set-positions` op with every live vertex snapped is appended. Returns
/// the result and log to keep (unchanged when the step stayed on the grid).
pub fn snap_step(
    grid: &Grid,
    base: &MeshData,
    result: MeshData,
    log: Vec<Op>,
) -> Result<(MeshData, Vec<Op>), EditError> {
    if grid.holds(&result.positions) {
        return Ok((result, log));
    }
    let mut store = MeshStore::new(base.clone());
    for op in log {
        store.apply(grid.snap_op(op))?;
    }
    if !grid.holds(store.positions()) {
        let mut xyz = store.positions().to_vec();
        grid.snap_all(&mut xyz);
        store.apply(Op::SetPositions { xyz })?;
    }
    Ok(store.finish())
}

impl Grid {
    /// `op` with the coordinates it carries snapped (matrices stay as they are).
    fn snap_op(&self, op: Op) -> Op {
        let snap_point =
            |at: Option<[f32; 3]>| at.map(|p| std::array::from_fn(|k| self.snap(k, p[k])));
        match op {
            Op::AddVertices { mut xyz } => {
                self.snap_all(&mut xyz);
                Op::AddVertices { xyz }
            }
            Op::MoveVertices { ids, mut xyz } => {
                self.snap_all(&mut xyz);
                Op::MoveVertices { ids, xyz }
            }
            Op::SetPositions { mut xyz } => {
                self.snap_all(&mut xyz);
                Op::SetPositions { xyz }
            }
            Op::SplitTriangle { triangle, at } => {
                Op::SplitTriangle { triangle, at: snap_point(at) }
            }
            Op::SplitEdge { edge, at } => Op::SplitEdge { edge, at: snap_point(at) },
            op => op,
        }
    }
}

fn power_of_ten(digits: u8) -> f64 {
    // Literals, exact (below 2^53), the same on every host.
    const POWERS: [f64; MAX_DIGITS as usize + 1] =
        [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12];
    POWERS[usize::from(digits)]
}

fn power_of_two(exponent: i32) -> f64 {
    // Exact for every exponent a grid allows (f64 normals reach 2^-1022).
    f64::from_bits(((exponent + 1023) as u64) << 52)
}

/// `⌈log2 x⌉` of a positive normal `f64` (an extent between `f32`s is one), exactly: from
/// the bits, not `log2`.
fn ceil_log2(x: f64) -> i32 {
    let bits = x.to_bits();
    let (field, mantissa) = (((bits >> 52) & 0x7ff) as i32, bits & ((1 << 52) - 1));
    field - 1023 + i32::from(mantissa != 0)
}

/// The exponent of one unit in the last place of a finite non-zero `f32`.
fn ulp_exponent(x: f32) -> i32 {
    lowest_bit_and_ulp(x.to_bits()).1
}

/// For the bits of a finite non-zero `f32`: the exponent of its lowest set bit and of its
/// unit in the last place.
fn lowest_bit_and_ulp(bits: u32) -> (i32, i32) {
    let field = ((bits >> 23) & 0xff) as i32;
    let mantissa = bits & 0x7f_ffff;
    // Subnormals have no implicit bit and the exponent of the smallest normal.
    let (significand, ulp) = match field {
        0 => (mantissa, MIN_EXPONENT),
        _ => (mantissa | 0x80_0000, field - 150),
    };
    (ulp + significand.trailing_zeros() as i32, ulp)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(positions: Vec<f32>) -> MeshData {
        MeshData::new(positions, vec![0, 1, 2])
    }

    #[test]
    fn the_grid_spans_the_box_in_at_most_two_to_the_bits_cells() {
        let m = mesh(vec![-1.5, 0.0, 10.0, 2.5, 0.001, 10.0, 0.0, 0.002, 10.0]);
        let grid = Grid::over(&m, 8).unwrap();
        for k in 0..2 {
            let extent = [4.0, 0.002][k];
            let cells = extent / grid.step(k);
            assert!(cells <= 256.0 && cells > 128.0, "axis {k}: {cells} cells");
        }
        // A flat axis gets the f32 resolution of its value.
        assert_eq!(grid.step(2), f64::from(10.0f32.next_up() - 10.0));
        assert_eq!(Grid::over(&m, 0), Err(QuantizeError::Bits(0)));
        assert_eq!(Grid::over(&m, 25), Err(QuantizeError::Bits(25)));
        let bad = mesh(vec![f32::NAN, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        assert_eq!(Grid::over(&bad, 8), Err(QuantizeError::NotFinite));
    }

    #[test]
    fn snapping_is_exact_idempotent_and_never_negative_zero() {
        let grid = Grid::from_exponents([-3, 0, 20]).unwrap();
        assert_eq!(grid.snap(0, 0.30), 0.25);
        assert_eq!(grid.snap(0, -0.0625).to_bits(), (-0.125f32).to_bits()); // ties away
        assert_eq!(grid.snap(1, -0.4).to_bits(), 0.0f32.to_bits());
        assert_eq!(grid.snap(2, f32::MAX), f32::MAX);
        assert!(!grid.is_on(1, -0.0));
        for x in [0.1f32, -7.3, 1e-30, 3.4e38, -1e9, 12345.678] {
            for k in 0..3 {
                let s = grid.snap(k, x);
                assert!(s.is_finite() && grid.is_on(k, s), "{x} on axis {k}");
                assert_eq!(grid.snap(k, s).to_bits(), s.to_bits());
            }
        }
    }

    #[test]
    fn detection_finds_a_quantised_grid_and_refuses_float_data() {
        let float_data: Vec<f32> = (1..10).map(|i| (i as f32 * 0.7).sin() * 3.0).collect();
        let mut m = mesh(float_data);
        assert_eq!(Grid::detect([&m.positions[..]]), None);
        let grid = quantize(&mut m, 10).unwrap();
        let found = Grid::detect([&m.positions[..]]).expect("on a grid");
        assert!(found.holds(&m.positions));
        for k in 0..3 {
            assert!(found.step(k) >= grid.step(k));
        }
        assert_eq!(Grid::detect([&[1.0f32, -0.0, 2.0][..]]), None);
    }

    #[test]
    fn detection_weighs_every_value_whatever_comes_first() {
        // Halves early, a quarter last: the grid is the quarters'.
        let quarters = [0.5f32, 1.5, 2.0, 3.5, 4.0, 5.5, 1.25, 2.5, 3.0];
        let found = Grid::detect([&quarters[..]]).expect("on a grid");
        assert_eq!(found.spacing(), Spacing::Binary([-2, -1, -1]));
        // A large value last coarsens the resolution every value is judged by: a grid of
        // 2^-20 is coarser than f32 around 1, not around 20 (where f32 steps are 2^-19).
        let mut large_last = vec![0.5f32, 0.25, 0.125, 0.75, 0.375, 0.625];
        large_last.extend([1.0 + 2f32.powi(-20), 1.0, 1.0]);
        let found = Grid::detect([&large_last[..]]).map(|g| g.spacing());
        assert_eq!(found, Some(Spacing::Binary([-20, -3, -3])));
        let mut then_larger = large_last.clone();
        then_larger.extend([20.0, 20.0, 20.0]);
        assert_eq!(Grid::detect([&then_larger[..]]), None);
        // Float data in the second set only, or a value that is not finite anywhere.
        let grid_values = [1.0f32, 2.0, 3.0];
        assert!(Grid::detect([&grid_values[..]]).is_some());
        let float_data: Vec<f32> = (1..4).map(|i| (i as f32 * 0.7).sin() * 3.0).collect();
        assert_eq!(Grid::detect([&grid_values[..], &float_data[..]]), None);
        assert_eq!(Grid::detect([&grid_values[..], &[1.0f32, f32::NAN, 3.0][..]]), None);
    }

    #[test]
    fn text_coordinates_with_fixed_decimals_are_a_decimal_grid() {
        // As parsed from an OBJ with up to three decimals.
        let text = ["0.1", "-2.25", "3.125", "1.7", "-0.4", "2.9", "-3.3", "0", "0.123"];
        let positions: Vec<f32> = text.iter().map(|t| t.parse().unwrap()).collect();
        let grid = Grid::detect([&positions[..]]).expect("a decimal grid");
        assert_eq!(grid.spacing(), Spacing::Decimal([3; 3]));
        for (k, &x) in positions.iter().enumerate() {
            let index = grid.index(k % 3, x);
            assert_eq!(grid.value(k % 3, index).to_bits(), x.to_bits(), "{x}");
            assert_eq!(grid.snap(k % 3, x).to_bits(), x.to_bits(), "{x} is on the grid");
        }
        // One more decimal anywhere needs the next digit; -0.0 is on no grid.
        let finer = [&positions[..], &[0.0625f32, 0.5, 0.25][..]];
        assert_eq!(Grid::detect(finer).map(|g| g.spacing()), Some(Spacing::Decimal([4; 3])));
        assert_eq!(Grid::detect([&[0.1f32, -0.0, 0.2][..]]), None);
        // Decimals finer than f32 can tell apart are no grid: plain float residuals.
        let too_fine = ["1234.5678", "2345.6789", "3456.7891"].map(|t| t.parse::<f32>().unwrap());
        assert_eq!(Grid::detect([&too_fine[..]]), None);
    }

    #[test]
    fn a_step_that_leaves_the_grid_is_snapped_back_with_one_set_positions() {
        let mut base = MeshData::new(
            vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
            vec![0, 1, 2, 0, 2, 3],
        );
        let grid = quantize(&mut base, 6).unwrap();
        let mut store = MeshStore::new(base.clone());
        store.apply(Op::SplitTriangle { triangle: 0, at: None }).unwrap();
        let (result, log) = store.finish();
        assert!(!grid.holds(&result.positions), "the centroid (2/3, 1/3) is off the grid");
        let (snapped, log) = snap_step(&grid, &base, result, log).unwrap();
        assert!(grid.holds(&snapped.positions));
        assert_eq!(log.len(), 2);
        assert!(matches!(log[1], Op::SetPositions { .. }));
        let (again, again_log) = snap_step(&grid, &base, snapped.clone(), log.clone()).unwrap();
        assert_eq!((again, again_log.len()), (snapped, 2));
    }
}
