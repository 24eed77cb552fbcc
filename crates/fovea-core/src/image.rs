//! A plain 2-D image container shared by every stage: row-major, top row first, pixel `(x, y)`
//! at index `y · width + x`. No colour semantics: `Image<[f32; 3]>` holds linear RGB,
//! `Image<f32>` a depth or luma plane.

use crate::error::{FoveaError, Result};

/// Largest number of pixels one image may hold (a 32768² image).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 30;

/// A row-major image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T> {
    width: u32,
    height: u32,
    data: Vec<T>,
}

impl<T: Clone> Image<T> {
    /// An image filled with `value`. Errors for a zero side or more than
    /// [`MAX_IMAGE_PIXELS`] pixels, before allocating.
    pub fn new(width: u32, height: u32, value: T) -> Result<Self> {
        let n = width as u64 * height as u64;
        if width == 0 || height == 0 {
            return Err(FoveaError::invalid(
                "image size",
                format!("{width}x{height}"),
                "both sides ≥ 1",
            ));
        }
        if n > MAX_IMAGE_PIXELS {
            return Err(FoveaError::ResourceLimit {
                what: format!("a {width}x{height} image"),
                needed: format!("{n} pixels"),
                limit: format!("{MAX_IMAGE_PIXELS} pixels"),
            });
        }
        Ok(Self {
            width,
            height,
            data: vec![value; n as usize],
        })
    }
}

impl<T> Image<T> {
    /// Wraps existing row-major data. Errors when the length is not `width · height`.
    pub fn from_vec(width: u32, height: u32, data: Vec<T>) -> Result<Self> {
        if data.len() as u64 != width as u64 * height as u64 || width == 0 || height == 0 {
            return Err(FoveaError::invalid(
                "image data",
                format!("{} values for {width}x{height}", data.len()),
                "width · height values, both sides ≥ 1",
            ));
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row-major.
    #[inline]
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// The pixels, row-major, mutable.
    #[inline]
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the image, returning its pixels.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// Pixel `(x, y)`. Panics when out of range (a programming error, not input).
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> &T {
        &self.data[y as usize * self.width as usize + x as usize]
    }

    /// Mutable pixel `(x, y)`.
    #[inline]
    pub fn get_mut(&mut self, x: u32, y: u32) -> &mut T {
        &mut self.data[y as usize * self.width as usize + x as usize]
    }

    /// Row `y`.
    #[inline]
    pub fn row(&self, y: u32) -> &[T] {
        let w = self.width as usize;
        &self.data[y as usize * w..(y as usize + 1) * w]
    }

    /// Applies `f` to every pixel, producing a new image.
    pub fn map<U>(&self, f: impl Fn(&T) -> U) -> Image<U> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(f).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_checked_before_allocating() {
        assert!(Image::new(0, 4, 0u8).is_err());
        assert!(matches!(
            Image::new(1 << 20, 1 << 20, 0u8),
            Err(FoveaError::ResourceLimit { .. })
        ));
        let mut im = Image::new(3, 2, 0u8).unwrap();
        *im.get_mut(2, 1) = 7;
        assert_eq!(im.data()[5], 7);
        assert_eq!(im.row(1), &[0, 0, 7]);
        assert!(Image::from_vec(2, 2, vec![1, 2, 3]).is_err());
    }
}
