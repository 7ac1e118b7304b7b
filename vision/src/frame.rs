//! Frames: 8- or 16-bit grayscale [`image::ImageBuffer`]s. Pixel `(i, j)` covers
//! `[i, i + 1) x [j, j + 1)` in image coordinates (x to the right, y down), so its centre is
//! at `(i + 0.5, j + 0.5)`: the convention of the plant's camera projection, in which a
//! point at `u` lies in pixel `floor(u)`.

use image::{ImageBuffer, Luma, Primitive};

/// A grayscale frame of samples `P` (`u8` or `u16`).
pub type Frame<P> = ImageBuffer<Luma<P>, Vec<P>>;

/// A sample type of a frame: `u8` (8-bit sensors) or `u16` (10- to 16-bit sensors).
pub trait Sample: Primitive + Ord + Send + Sync + 'static {
    /// The largest digital number a sample holds.
    const MAX_DN: u32;
    /// The sample of a digital number, clamped to `0..=MAX_DN`.
    fn from_dn(dn: u32) -> Self;
    /// The sample's digital number.
    fn dn(self) -> u32;
}

macro_rules! sample {
    ($t:ty) => {
        impl Sample for $t {
            const MAX_DN: u32 = <$t>::MAX as u32;
            fn from_dn(dn: u32) -> $t {
                dn.min(Self::MAX_DN) as $t
            }
            fn dn(self) -> u32 {
                self as u32
            }
        }
    };
}

sample!(u8);
sample!(u16);
