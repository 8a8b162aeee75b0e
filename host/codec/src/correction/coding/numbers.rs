//! Numbers of any attribute type coded exactly: each against a prediction, through its
//! *image*, an integer of the type's width (a float's order-preserving bits, see
//! [`float`](super::float)), so a residual counts the representable values between
//! prediction and value, and adding it back gives the exact bits whatever the prediction.
//!
//! [`ValueModels`] codes a component's residual under an adaptive model per component and
//! per magnitude class of the residual coded before it (bytes as one symbol, wider numbers
//! as a bit-length bucket and raw low bits), or, when asked, as one of the component's
//! recent values. Packed meshes (`pack/values.rs`) and corrections' `set-attribute` values
//! share it.

use super::float::ordered;
use super::model::AdaptiveModel;
use super::stream::{CorruptStream, SymbolReader, SymbolWriter};

/// Magnitude classes of a residual: the context of the next one.
const CLASSES: usize = 6;
/// Most numbers per element.
pub(crate) const MAX_COMPONENTS: usize = 4;
/// Residuals below this are their own bucket; above, bit length and the next bit.
const LITERALS: u64 = 16;
/// Buckets for residuals up to 64 bits.
const BUCKETS: usize = LITERALS as usize + 2 * 60;

/// A number type as the coder sees it: its image and the nearest value to a mean.
pub(crate) trait Number: Copy + Default {
    /// Bits of the image.
    const BITS: u32;
    fn image(self) -> u64;
    fn from_image(image: u64) -> Self;
    fn value(self) -> f64;
    /// The image of the number nearest `x` (a mean of numbers of this type).
    fn nearest_image(x: f64) -> u64;
}

impl Number for u8 {
    const BITS: u32 = 8;
    fn image(self) -> u64 {
        u64::from(self)
    }
    fn from_image(image: u64) -> Self {
        image as u8
    }
    fn value(self) -> f64 {
        f64::from(self)
    }
    fn nearest_image(x: f64) -> u64 {
        x.round().clamp(0.0, 255.0) as u8 as u64
    }
}

impl Number for i32 {
    const BITS: u32 = 32;
    fn image(self) -> u64 {
        u64::from(self as u32)
    }
    fn from_image(image: u64) -> Self {
        image as u32 as i32
    }
    fn value(self) -> f64 {
        f64::from(self)
    }
    fn nearest_image(x: f64) -> u64 {
        (x.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32).image()
    }
}

impl Number for u32 {
    const BITS: u32 = 32;
    fn image(self) -> u64 {
        u64::from(self)
    }
    fn from_image(image: u64) -> Self {
        image as u32
    }
    fn value(self) -> f64 {
        f64::from(self)
    }
    fn nearest_image(x: f64) -> u64 {
        u64::from(x.round().clamp(0.0, f64::from(u32::MAX)) as u32)
    }
}

impl Number for f32 {
    const BITS: u32 = 32;
    fn image(self) -> u64 {
        u64::from(ordered(self) as u32)
    }
    fn from_image(image: u64) -> Self {
        let i = image as u32 as i32;
        f32::from_bits((i ^ ((((i >> 31) as u32) >> 1) as i32)) as u32)
    }
    fn value(self) -> f64 {
        f64::from(self)
    }
    fn nearest_image(x: f64) -> u64 {
        (x as f32).image()
    }
}

impl Number for f64 {
    const BITS: u32 = 64;
    fn image(self) -> u64 {
        let b = self.to_bits() as i64;
        (b ^ ((((b >> 63) as u64) >> 1) as i64)) as u64
    }
    fn from_image(image: u64) -> Self {
        let i = image as i64;
        f64::from_bits((i ^ ((((i >> 63) as u64) >> 1) as i64)) as u64)
    }
    fn value(self) -> f64 {
        self
    }
    fn nearest_image(x: f64) -> u64 {
        x.image()
    }
}

/// The width mask of `T`'s images.
pub(crate) fn mask<T: Number>() -> u64 {
    if T::BITS == 64 { u64::MAX } else { (1u64 << T::BITS) - 1 }
}

/// The signed difference `a - b` of two images of `T`.
pub(crate) fn difference<T: Number>(a: u64, b: u64) -> i64 {
    let shift = 64 - T::BITS;
    ((a.wrapping_sub(b) << shift) as i64) >> shift
}

pub(crate) fn zigzag(r: i64) -> u64 {
    ((r << 1) ^ (r >> 63)) as u64
}

pub(crate) fn unzigzag(z: u64) -> i64 {
    ((z >> 1) as i64) ^ -((z & 1) as i64)
}

fn class_of(z: u64) -> usize {
    match z {
        0 => 0,
        1..4 => 1,
        4..32 => 2,
        32..1024 => 3,
        1024..0x10_0000 => 4,
        _ => 5,
    }
}

/// Values remembered per component, most recent first.
pub(crate) const RECENT: usize = 32;
/// No recent value matches.
pub(crate) const MISS: u8 = u8::MAX;
/// Bit 0 of an attribute's mask: a component may name one of its recent values instead of
/// a residual. Bits 1 to 3 are the decorrelated components.
pub(crate) const RECENT_VALUES: u8 = 1;

/// A component's recent distinct values, most recent first.
#[derive(Default)]
pub(crate) struct Recent(pub(crate) Vec<u64>);

impl Recent {
    pub(crate) fn find(&self, x: u64) -> Option<usize> {
        self.0.iter().position(|&y| y == x)
    }

    /// Moves `x` to the front.
    pub(crate) fn saw(&mut self, x: u64) {
        match self.find(x) {
            Some(i) => self.0[..=i].rotate_right(1),
            None => {
                if self.0.len() == RECENT {
                    self.0.pop();
                }
                self.0.insert(0, x);
            }
        }
    }
}

/// The models and state of one attribute's coding, the same on both sides.
pub(crate) struct ValueModels {
    residual: Vec<AdaptiveModel>,
    class: usize,
    /// `None` unless the attribute names recent values.
    recent: Option<Vec<Recent>>,
    /// Per component and whether the component before hit: 0 residual, `1 + i` recent `i`.
    which: Vec<AdaptiveModel>,
    hit: bool,
}

impl ValueModels {
    pub(crate) fn new<T: Number>(components: usize, mask: u8) -> Self {
        let symbols = if T::BITS == 8 { 256 } else { BUCKETS };
        let recent = mask & RECENT_VALUES != 0;
        Self {
            residual: (0..components * CLASSES).map(|_| AdaptiveModel::new(symbols)).collect(),
            class: 0,
            recent: recent.then(|| (0..components).map(|_| Recent::default()).collect()),
            which: match recent {
                true => (0..2 * components).map(|_| AdaptiveModel::new(RECENT + 1)).collect(),
                false => Vec::new(),
            },
            hit: false,
        }
    }

    /// Codes component `k`'s value `actual` against `predicted`.
    pub(crate) fn write<T: Number>(
        &mut self,
        w: &mut SymbolWriter,
        k: usize,
        actual: u64,
        predicted: u64,
    ) {
        let z = zigzag(difference::<T>(actual, predicted));
        if let Some(recent) = &mut self.recent {
            let hit = if z == 0 { None } else { recent[k].find(actual) };
            recent[k].saw(actual);
            let model = &mut self.which[2 * k + usize::from(self.hit)];
            w.symbol(model, hit.map_or(0, |i| i + 1));
            self.hit = hit.is_some();
            if self.hit {
                return;
            }
        }
        self.write_residual::<T>(w, k, z);
    }

    /// The value of component `k` predicted as `predicted`.
    pub(crate) fn read<T: Number>(
        &mut self,
        r: &mut SymbolReader,
        k: usize,
        predicted: u64,
    ) -> Result<u64, CorruptStream> {
        if let Some(recent) = &mut self.recent {
            let model = &mut self.which[2 * k + usize::from(self.hit)];
            let which = r.symbol(model)?;
            self.hit = which > 0;
            if which > 0 {
                let actual = *recent[k].0.get(which - 1).ok_or(CorruptStream)?;
                recent[k].saw(actual);
                return Ok(actual);
            }
        }
        let z = self.read_residual::<T>(r, k)?;
        let actual = predicted.wrapping_add(unzigzag(z) as u64) & mask::<T>();
        if let Some(recent) = &mut self.recent {
            recent[k].saw(actual);
        }
        Ok(actual)
    }

    fn write_residual<T: Number>(&mut self, w: &mut SymbolWriter, k: usize, z: u64) {
        let model = &mut self.residual[k * CLASSES + self.class];
        if T::BITS == 8 || z < LITERALS {
            w.symbol(model, z as usize);
        } else {
            let length = 64 - z.leading_zeros(); // 5..=64
            let raw = length - 2;
            let bucket = LITERALS as u32 + 2 * (length - 5) + ((z >> raw) & 1) as u32;
            w.symbol(model, bucket as usize);
            w.raw(raw.min(32), z as u32);
            if raw > 32 {
                w.raw(raw - 32, (z >> 32) as u32);
            }
        }
        self.class = class_of(z);
    }

    fn read_residual<T: Number>(
        &mut self,
        r: &mut SymbolReader,
        k: usize,
    ) -> Result<u64, CorruptStream> {
        let model = &mut self.residual[k * CLASSES + self.class];
        let bucket = r.symbol(model)? as u64;
        let z = if T::BITS == 8 || bucket < LITERALS {
            bucket
        } else {
            let length = (bucket - LITERALS) / 2 + 5;
            let raw = (length - 2) as u32;
            let second = (bucket - LITERALS) % 2;
            let mut low = u64::from(r.raw(raw.min(32))?);
            if raw > 32 {
                low |= u64::from(r.raw(raw - 32)?) << 32;
            }
            if length > u64::from(T::BITS) {
                return Err(CorruptStream);
            }
            (1 << (length - 1)) | (second << raw) | low
        };
        self.class = class_of(z);
        Ok(z)
    }
}

/// The prediction of component `k` after decorrelation: plus the previous component's
/// residual from its own prediction when `mask` has bit `k`.
pub(crate) fn adjusted<T: Number>(base: u64, k: usize, mask: u8, previous_residual: i64) -> u64 {
    if k > 0 && mask & (1 << k) != 0 {
        base.wrapping_add(previous_residual as u64) & self::mask::<T>()
    } else {
        base
    }
}

/// Roughly the bits a residual costs: nothing for zero, else its length and a bit.
pub(crate) fn cost(z: u64) -> f64 {
    if z == 0 { 0.0 } else { f64::from(65 - z.leading_zeros()) }
}

/// What a component's values would cost one way: residuals, and with recent values.
#[derive(Clone, Copy, Default)]
pub(crate) struct Costs {
    residuals: f64,
    /// With recent values: the residuals of misses, the ranks of hits, how many hit.
    misses: f64,
    ranks: f64,
    hits: f64,
}

impl Costs {
    pub(crate) fn add(&mut self, z: u64, rank: u8) {
        self.residuals += cost(z);
        if z != 0 && rank != MISS {
            self.ranks += 1.0 + f64::from(rank + 1).log2();
            self.hits += 1.0;
        } else {
            self.misses += cost(z);
        }
    }

    /// Without recent values.
    pub(crate) fn plain(&self) -> f64 {
        self.residuals
    }

    /// With recent values, over `n` elements: the hit-or-miss choice as its entropy.
    pub(crate) fn with_recent(&self, n: f64) -> f64 {
        let p = self.hits / n;
        let flags = if p <= 0.0 || p >= 1.0 {
            0.0
        } else {
            -n * (p * p.log2() + (1.0 - p) * (1.0 - p).log2())
        };
        self.misses + self.ranks + flags
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_keep_bits_and_order() {
        for x in [0.0f32, -0.0, 1.0, -1.0, f32::MIN_POSITIVE, f32::MAX, f32::MIN, 1e-45] {
            assert_eq!(f32::from_image(x.image()).to_bits(), x.to_bits());
        }
        for x in [0.0f64, -0.0, 1.0, -1.0, f64::MIN_POSITIVE, f64::MAX, f64::MIN, 5e-324] {
            assert_eq!(f64::from_image(x.image()).to_bits(), x.to_bits());
        }
        // Images wrap, so order shows in differences: -0.0 is one step below 0.0.
        assert!(difference::<f32>((-0.0f32).image(), (-1.0f32).image()) > 0);
        assert_eq!(difference::<f32>(0.0f32.image(), (-0.0f32).image()), 1);
        assert_eq!(difference::<f32>(1.5f32.image(), 1.0f32.image()), 1 << 22);
        assert_eq!(difference::<u8>(1, 255), 2);
        assert_eq!(difference::<i32>((-1i32).image(), 2i32.image()), -3);
        for z in [0, 1, 2, 255, u64::MAX, 1 << 63] {
            assert_eq!(zigzag(unzigzag(z)), z);
        }
    }

    #[test]
    fn recent_values_move_to_the_front_and_the_oldest_goes() {
        let mut recent = Recent::default();
        for x in 0..RECENT as u64 + 3 {
            recent.saw(x);
        }
        assert_eq!(recent.0.len(), RECENT);
        assert_eq!(recent.find(RECENT as u64 + 2), Some(0));
        assert_eq!(recent.find(2), None);
        recent.saw(10);
        assert_eq!(recent.find(10), Some(0));
        assert_eq!(recent.find(RECENT as u64 + 2), Some(1));
    }
}
