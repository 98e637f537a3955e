//! Where rendered lines go: a [`FrameSink`] (a link encoder, a PNG
//! writer, a test's buffer) and what carries between lines ([`Carry`]).

use crate::render::sensor::sampling::Corners;
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

/// What a frame's lines, rendered in order, pass from one to the next
/// ([`crate::render::Frame::render_line_in`]; [`crate::render::Frame::render_carried`] holds one a
/// frame): the sampled loop's corner keys and, with the fast arithmetic,
/// its chunk buffers ([`crate::render::fast::ChunkBufs`]).
#[derive(Debug)]
pub struct Carry<'a> {
    // (Read by the fast arithmetic's sampled loop alone.)
    #[cfg_attr(not(feature = "mix32"), allow(dead_code))]
    pub(crate) corners: Corners<'a>,
    #[cfg(feature = "mix32")]
    pub(crate) chunk: crate::render::fast::ChunkBufs,
}

impl<'a> Carry<'a> {
    /// A carry for a new frame, with `keys` for the corner keys
    /// ([`Corners::new`]).
    pub fn new(keys: &'a mut [u64]) -> Carry<'a> {
        Carry {
            corners: Corners::new(keys),
            #[cfg(feature = "mix32")]
            chunk: crate::render::fast::ChunkBufs::EMPTY,
        }
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
