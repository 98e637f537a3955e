//! Where rendered lines go: a [`FrameSink`] (a link encoder, a PNG
//! writer, a caller's [`Image`]), and the line buffers a frame renders
//! through ([`LineBuffers`]).

use crate::scene::PixelFormat;

/// What a [`FrameSink`] is told when a frame begins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameInfo {
    /// Width, pixels.
    pub width: u16,
    /// Height, pixels (lines).
    pub height: u16,
    /// Pixel format.
    pub format: PixelFormat,
}

/// The buffers a frame renders through ([`crate::render::Frame::render`]):
/// one line of pixels (where the sink does not place lines itself; may be
/// empty where it always does), one line of flags (at least the width),
/// and the corner keys pixel-area sampling carries from line to line
/// (`width + 1` words; shorter, none carried).
#[derive(Debug)]
pub struct LineBuffers<'a> {
    pub(crate) pixels: &'a mut [u8],
    pub(crate) flags: &'a mut [u8],
    pub(crate) keys: &'a mut [u64],
}

impl<'a> LineBuffers<'a> {
    /// A line of `pixels` and one of `flags`, no corner keys.
    pub fn new(pixels: &'a mut [u8], flags: &'a mut [u8]) -> LineBuffers<'a> {
        LineBuffers {
            pixels,
            flags,
            keys: &mut [],
        }
    }

    /// These buffers with `keys` for the corner keys.
    pub fn with_keys(self, keys: &'a mut [u64]) -> LineBuffers<'a> {
        LineBuffers { keys, ..self }
    }
}

/// A whole frame in one caller's buffer: line `y` rendered in place at
/// `y · line_bytes`, and each line's flags, if asked for, at `y · width`.
#[derive(Debug)]
pub struct Image<'a> {
    pixels: &'a mut [u8],
    flags: Option<&'a mut [u8]>,
    width: usize,
}

/// An [`Image`] too small for the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageTooSmall;

impl core::fmt::Display for ImageTooSmall {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the image buffer is smaller than the frame")
    }
}

impl core::error::Error for ImageTooSmall {}

impl<'a> Image<'a> {
    /// An image in `pixels` (at least `line_bytes · height`), without flags.
    pub fn new(pixels: &'a mut [u8]) -> Image<'a> {
        Image {
            pixels,
            flags: None,
            width: 0,
        }
    }

    /// This image with each pixel's flags ([`crate::render::FLAG_OUTSIDE_FIELD`])
    /// in `flags` (at least `width · height`).
    pub fn with_flags(self, flags: &'a mut [u8]) -> Image<'a> {
        Image {
            flags: Some(flags),
            ..self
        }
    }
}

impl FrameSink for Image<'_> {
    type Error = ImageTooSmall;

    fn begin(&mut self, info: &FrameInfo) -> Result<(), ImageTooSmall> {
        let (w, h) = (info.width as usize, info.height as usize);
        let line = w * info.format.bytes_per_pixel();
        let flags_fit = self.flags.as_ref().is_none_or(|f| f.len() >= w * h);
        if self.pixels.len() < line * h || !flags_fit {
            return Err(ImageTooSmall);
        }
        self.width = w;
        Ok(())
    }

    fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), ImageTooSmall> {
        let n = pixels.len();
        let at = y as usize * n;
        let dst = self.pixels.get_mut(at..at + n).ok_or(ImageTooSmall)?;
        dst.copy_from_slice(pixels);
        self.placed(y, flags)
    }

    fn place(&mut self, y: u16, len: usize) -> Result<Option<&mut [u8]>, ImageTooSmall> {
        let at = y as usize * len;
        self.pixels.get_mut(at..at + len).map(Some).ok_or(ImageTooSmall)
    }

    fn placed(&mut self, y: u16, flags: &[u8]) -> Result<(), ImageTooSmall> {
        let (w, at) = (self.width, y as usize * self.width);
        if let Some(all) = self.flags.as_deref_mut() {
            let (dst, src) = (all.get_mut(at..at + w), flags.get(..w));
            dst.zip(src)
                .ok_or(ImageTooSmall)?
                .0
                .copy_from_slice(src.unwrap_or_default());
        }
        Ok(())
    }
}

/// Receives a rendered frame: [`FrameSink::begin`], every line in order,
/// [`FrameSink::end`]. The link's [`crate::link::Stream`], the host's
/// collectors and the timing adapter [`Timed`] are sinks.
pub trait FrameSink {
    /// The sink's error.
    type Error;
    /// The frame begins.
    fn begin(&mut self, _info: &FrameInfo) -> Result<(), Self::Error> {
        Ok(())
    }
    /// Line `y`: `pixels` holds `width × bytes_per_pixel` bytes, `flags` one
    /// byte of `FLAG_*` bits a pixel.
    fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error>;
    /// Where line `y` (`len` bytes) is to be rendered if the sink holds
    /// that place itself (a link encoder's chunk: the line is then not
    /// copied, and [`FrameSink::placed`] follows instead of
    /// [`FrameSink::line`]); `None` (the default): in the caller's buffer.
    fn place(&mut self, _y: u16, _len: usize) -> Result<Option<&mut [u8]>, Self::Error> {
        Ok(None)
    }
    /// Line `y` was rendered where [`FrameSink::place`] said; `flags` as
    /// for [`FrameSink::line`]. A sink that places lines implements this
    /// (the default does nothing with them).
    fn placed(&mut self, _y: u16, _flags: &[u8]) -> Result<(), Self::Error> {
        Ok(())
    }
    /// The frame ends; `cost` is what rendering it cost when an adapter
    /// ([`Timed`]) measured it.
    fn end(&mut self, _cost: Option<u64>) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// A timing adapter: measures the renderer, not the sink. The time spent
/// between the inner sink's calls (plus `already`, e.g. the frame's
/// preparation), converted by `to_cost`, is passed to the inner sink's
/// [`FrameSink::end`] as the frame's cost — so a slow link's back-pressure
/// is not counted. Between [`FrameSink::placed`] and the next call
/// nothing is rendered: that gap is not timed, so a placed line costs two
/// clock reads, as a copied one does.
pub struct Timed<K, C, T> {
    /// The sink timed.
    pub inner: K,
    clock: C,
    to_cost: T,
    spent: u64,
    /// The clock when the inner sink last returned, if the time since is
    /// the renderer's.
    last: Option<u64>,
}

impl<K: FrameSink, C: FnMut() -> u64, T: Fn(u64) -> u64> Timed<K, C, T> {
    /// Starts timing now; `already` clock ticks are counted in.
    pub fn new(inner: K, mut clock: C, to_cost: T, already: u64) -> Self {
        let last = Some(clock());
        Timed {
            inner,
            clock,
            to_cost,
            spent: already,
            last,
        }
    }

    /// The cost so far (`to_cost` of the ticks counted).
    pub fn cost(&self) -> u64 {
        (self.to_cost)(self.spent)
    }

    fn lap(&mut self) {
        if let Some(last) = self.last {
            let now = (self.clock)();
            self.spent = self.spent.wrapping_add(now.wrapping_sub(last));
        }
    }
}

impl<K: FrameSink, C: FnMut() -> u64, T: Fn(u64) -> u64> FrameSink for Timed<K, C, T> {
    type Error = K::Error;
    fn begin(&mut self, info: &FrameInfo) -> Result<(), Self::Error> {
        self.lap();
        let r = self.inner.begin(info);
        self.last = Some((self.clock)());
        r
    }
    fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error> {
        self.lap();
        let r = self.inner.line(y, pixels, flags);
        self.last = Some((self.clock)());
        r
    }
    fn place(&mut self, y: u16, len: usize) -> Result<Option<&mut [u8]>, Self::Error> {
        self.lap();
        let r = self.inner.place(y, len);
        self.last = Some((self.clock)());
        r
    }
    fn placed(&mut self, y: u16, flags: &[u8]) -> Result<(), Self::Error> {
        self.lap();
        // Until the next place (or the end): not the renderer's time.
        self.last = None;
        self.inner.placed(y, flags)
    }
    fn end(&mut self, _cost: Option<u64>) -> Result<(), Self::Error> {
        self.lap();
        let cost = self.cost();
        let r = self.inner.end(Some(cost));
        self.last = Some((self.clock)());
        r
    }
}
