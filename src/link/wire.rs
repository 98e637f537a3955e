//! The messages on the wire, both directions (`docs/wire.md`): camera →
//! host ([`Message`]: a frame's start, chunks, flags and end; answers) and
//! host → camera ([`Request`], [`Command`]), the CRC-32 and the canonical
//! encoding rule.

use crate::render::{Arithmetic, DistortionEval, RenderModel, Stages};
use crate::scene::{PixelFormat, Scene};
use serde::{Deserialize, Serialize};

/// The protocol version this crate speaks (`docs/wire.md`): 2 adds the
/// frame's ground truth and the host → camera commands
/// ([`crate::link::control`]); 3 the lens and the projection's value to the
/// truth, enough to render the frame again; 4 a calibrated lens to the
/// scene data.
pub const PROTOCOL_VERSION: u8 = 4;

/// CRC-32/ISO-HDLC (the zlib/Ethernet CRC): polynomial 0x04C11DB7 reflected,
/// initial value and final XOR 0xFFFFFFFF; check value 0xCBF43926.
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Largest postcard header of a [`Chunk`] message (tag, frame id, first
/// line, offset, length varints), in bytes.
pub const CHUNK_HEADER_MAX: usize = 1 + 5 + 3 + 5 + 5;

/// The chunk buffer the shipped senders use, bytes: 12 lines of 160 Gray8
/// pixels per message, link efficiency above 0.98 for 160×120 Gray8.
pub const DEFAULT_CHUNK: usize = 2048;

/// Largest body of any message but a [`Chunk`], bytes: a [`FrameStart`]
/// with every varint at its longest (30 bytes of header, 238 of truth).
/// Replies are shorter (a [`Reject`] names a field of at most
/// [`crate::link::FIELD_MAX`] bytes).
pub const MESSAGE_MAX: usize = 268;

/// The encoded size a chunk buffer of `chunk` bytes needs: the largest
/// message (a chunk's, or [`MESSAGE_MAX`]), its CRC, COBS's overhead, and
/// the delimiter.
pub const fn wire_size(chunk: usize) -> usize {
    let body = if chunk + CHUNK_HEADER_MAX > MESSAGE_MAX {
        chunk + CHUNK_HEADER_MAX
    } else {
        MESSAGE_MAX
    };
    let msg = body + 4;
    msg + msg / 254 + 2
}

/// Pixel format on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WireFormat {
    /// One byte a pixel.
    Gray8,
    /// Two bytes a pixel, little-endian, `bits` significant.
    Gray16 {
        /// Significant bits (9 to 16).
        bits: u8,
    },
    /// Two bytes a pixel, little-endian `r << 11 | g << 5 | b`.
    Rgb565,
}

impl From<PixelFormat> for WireFormat {
    fn from(f: PixelFormat) -> Self {
        match f {
            PixelFormat::Gray8 => WireFormat::Gray8,
            PixelFormat::Gray16 { bits } => WireFormat::Gray16 { bits },
            PixelFormat::Rgb565 => WireFormat::Rgb565,
        }
    }
}

impl WireFormat {
    /// The pixel format a received frame holds (a receiver checks `bits`
    /// first: 9 to 16).
    pub const fn pixel_format(self) -> PixelFormat {
        match self {
            WireFormat::Gray8 => PixelFormat::Gray8,
            WireFormat::Gray16 { bits } => PixelFormat::Gray16 { bits },
            WireFormat::Rgb565 => PixelFormat::Rgb565,
        }
    }

    /// Bytes a pixel.
    pub const fn bytes_per_pixel(self) -> usize {
        match self {
            WireFormat::Gray8 => 1,
            _ => 2,
        }
    }
}

/// Opens a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameStart {
    /// [`PROTOCOL_VERSION`].
    pub version: u8,
    /// Frame counter (consecutive; wraps).
    pub frame_id: u32,
    /// Width, pixels.
    pub width: u16,
    /// Height, pixels.
    pub height: u16,
    /// Pixel format.
    pub format: WireFormat,
    /// Which scene the frame shows (the sender's numbering).
    pub scene_id: u32,
    /// Exposure `K` (DN per W/m²) as I32F32 raw bits.
    pub exposure: i64,
    /// What made the frame: the camera, its pose and the plan.
    pub truth: Truth,
}

/// A frame's ground truth: the camera that formed it, exactly as the core
/// held it (each value the raw bits of its fixed-point format, so that a
/// receiver can rebuild the very numbers the camera used; divide by the
/// power of two given to get SI units), and the plan it was rendered with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Truth {
    /// When the camera began sending the frame (after planning and
    /// preparing it), ns in the camera's time base (QEMU: virtual time
    /// under `-icount`).
    pub timestamp_ns: u64,
    /// Sequence number of the last command the camera had processed when
    /// the frame began (`None`: none yet). Every command up to it is in
    /// effect, none after it.
    pub command: Option<u32>,
    /// `R` (rows: the camera's axes in world coordinates), camera-model.md
    /// §1, I2F62: `R_ij = rotation[i][j] / 2⁶²`.
    pub rotation: [[i64; 3]; 3],
    /// `T`, the centre of projection in world coordinates, I24F40: metres
    /// = value / 2⁴⁰.
    pub translation: [i64; 3],
    /// Focal length `f`, I24F40: metres = value / 2⁴⁰.
    pub focal_length: i64,
    /// Pixel pitch `(s_x, s_y)`, I4F60: metres = value / 2⁶⁰.
    pub pitch: [i64; 2],
    /// Principal point `(o_x, o_y)`, I16F16: pixels = value / 2¹⁶ (pixel
    /// centres at integers).
    pub principal_point: [i32; 2],
    /// Radial distortion `(k1, k2)` of camera-model.md §3 (distorted →
    /// undistorted), I16F48: value / 2⁴⁸; `(0, 0)` without distortion.
    pub distortion: [i64; 2],
    /// The thin lens (§4): aperture diameter `D` and focus distance, I24F40:
    /// metres = value / 2⁴⁰.
    pub lens: [i64; 2],
    /// The projection's own value ([`WirePlan::model`]): weak perspective's
    /// mean depth `Z̄`, I24F40 (metres = value / 2⁴⁰); orthographic's scale
    /// `m`, I16F48 (value / 2⁴⁸); 0 for perspective.
    pub model_scale: i64,
    /// How the frame was rendered.
    pub plan: WirePlan,
}

/// The rendering a frame got (the planner's choice, or a forced one), in
/// the small codes `docs/wire.md` lists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WirePlan {
    /// 0 fast (32-bit, a format per quantity), 1 wide.
    pub arithmetic: u8,
    /// 0 perspective, 1 weak perspective, 2 orthographic.
    pub model: u8,
    /// 0 none, 1 polynomial, 2 table (nearest entry), 3 table (linear).
    pub distortion: u8,
    /// Distortion table entries (0 without a table).
    pub table_entries: u16,
    /// Sample grid side (1: the pixel centre).
    pub samples: u8,
    /// The adaptive sampling rule.
    pub adaptive: bool,
    /// Aperture pattern points (0: pinhole).
    pub aperture: u16,
    /// Sensor noise.
    pub noise: bool,
}

impl From<&Stages> for WirePlan {
    fn from(s: &Stages) -> Self {
        WirePlan {
            arithmetic: match s.arithmetic {
                Arithmetic::Fast => 0,
                Arithmetic::Wide => 1,
            },
            model: match s.model {
                RenderModel::Perspective => 0,
                RenderModel::WeakPerspective { .. } => 1,
                RenderModel::Orthographic { .. } => 2,
            },
            distortion: match s.distortion {
                None => 0,
                Some(DistortionEval::Polynomial) => 1,
                Some(DistortionEval::Nearest) => 2,
                Some(DistortionEval::Linear) => 3,
            },
            table_entries: s.distortion_lut.map_or(0, |n| n.min(u16::MAX as usize) as u16),
            samples: s.samples,
            adaptive: s.adaptive,
            aperture: s.aperture,
            noise: s.noise,
        }
    }
}

impl Truth {
    /// The truth of a frame of `scene` rendered with `stages`.
    #[inline(never)]
    pub fn of(scene: &Scene, stages: &Stages, timestamp_ns: u64, command: Option<u32>) -> Truth {
        let cam = &scene.camera;
        let i = &cam.intrinsics;
        let e = &cam.extrinsics;
        let (sx, sy) = i.pitch();
        let (ox, oy) = i.principal_point();
        let (k1, k2) = scene.distortion.coefficients();
        let t = e.translation();
        Truth {
            timestamp_ns,
            command,
            rotation: e.rotation().map(|row| row.map(|v| v.to_bits())),
            translation: [t.x.to_bits(), t.y.to_bits(), t.z.to_bits()],
            focal_length: i.focal_length().to_bits(),
            pitch: [sx.to_bits(), sy.to_bits()],
            principal_point: [ox.to_bits(), oy.to_bits()],
            distortion: [k1.to_bits(), k2.to_bits()],
            lens: [
                cam.lens().diameter().to_bits(),
                cam.lens().focus_distance().to_bits(),
            ],
            model_scale: match cam.model() {
                crate::Model::Perspective => 0,
                crate::Model::WeakPerspective { mean_depth } => mean_depth.to_bits(),
                crate::Model::Orthographic { scale } => scale.to_bits(),
            },
            plan: WirePlan::from(stages),
        }
    }
}

impl FrameStart {
    /// The header of frame `frame_id` of scene `scene_id`, rendered with
    /// `stages`, its truth taken from `scene`.
    #[inline(never)]
    pub fn of(
        frame_id: u32,
        scene_id: u32,
        scene: &Scene,
        stages: &Stages,
        timestamp_ns: u64,
        command: Option<u32>,
    ) -> FrameStart {
        let (width, height) = scene.camera.intrinsics.size();
        FrameStart {
            version: PROTOCOL_VERSION,
            frame_id,
            width,
            height,
            format: WireFormat::from(scene.format),
            scene_id,
            exposure: scene.exposure.to_bits(),
            truth: Truth::of(scene, stages, timestamp_ns, command),
        }
    }

    /// Bytes of pixel data the frame carries.
    pub const fn frame_bytes(&self) -> usize {
        self.width as usize * self.height as usize * self.format.bytes_per_pixel()
    }

    /// Bytes of one line.
    pub const fn line_bytes(&self) -> usize {
        self.width as usize * self.format.bytes_per_pixel()
    }
}

/// Consecutive whole lines of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Chunk<'a> {
    /// The frame's id.
    pub frame_id: u32,
    /// First line in the chunk.
    pub first_line: u16,
    /// Offset of the first byte within the frame's pixel bytes.
    pub offset: u32,
    /// Pixel bytes (serialized as a byte string: length, then the bytes).
    #[serde(with = "serde_bytes", borrow)]
    pub data: &'a [u8],
}

/// Closes a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameEnd {
    /// The frame's id.
    pub frame_id: u32,
    /// CRC-32 of all the frame's pixel bytes, in order.
    pub crc: u32,
    /// Pixels outside the lens field ([`crate::render::FLAG_OUTSIDE_FIELD`]),
    /// as the frame's [`LineFlags`] messages gave them (0: none, and no
    /// such message).
    pub outside: u32,
    /// What the frame cost the device (instructions), when it knows.
    pub cost: Option<u64>,
}

/// The pixels of one line outside the lens field (`camera-model.md`: beyond
/// the distortion's fold radius, their value 0): sent inside a frame, after
/// that line's [`FrameStart`] and before its [`FrameEnd`], for each line
/// that has any (a scene without them sends none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LineFlags<'a> {
    /// The frame's id.
    pub frame_id: u32,
    /// The line.
    pub line: u16,
    /// One bit a pixel, `⌈width/8⌉` bytes: pixel `i` is bit `i mod 8`
    /// (least significant first) of byte `i / 8`; bits past the width 0.
    #[serde(borrow, with = "serde_bytes")]
    pub bits: &'a [u8],
}

/// A line's flags (a byte a pixel) sent as [`LineFlags`], packed while
/// serialized: the same bytes, no buffer.
pub(crate) struct FlagsOut<'a> {
    pub(crate) frame_id: u32,
    pub(crate) line: u16,
    pub(crate) flags: &'a [u8],
}

/// The packed bits of a flags line, as postcard writes a byte string
/// (length, then the bytes).
struct PackedBits<'a>(&'a [u8]);

impl Serialize for PackedBits<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let mut seq = s.serialize_seq(Some(self.0.len().div_ceil(8)))?;
        for eight in self.0.chunks(8) {
            let byte = eight.iter().enumerate().fold(0u8, |b, (i, f)| {
                b | (u8::from(*f & crate::render::FLAG_OUTSIDE_FIELD != 0) << i)
            });
            seq.serialize_element(&byte)?;
        }
        seq.end()
    }
}

impl Serialize for FlagsOut<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.frame_id, self.line, PackedBits(self.flags)).serialize(s)
    }
}

/// A message on the wire, camera → host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message<'a> {
    /// Tag 0.
    FrameStart(FrameStart),
    /// Tag 1.
    #[serde(borrow)]
    Chunk(Chunk<'a>),
    /// Tag 2.
    FrameEnd(FrameEnd),
    /// Tag 3: a command was applied ([`crate::link::control`]).
    Ack(Ack),
    /// Tag 4: a command was refused, and why.
    #[serde(borrow)]
    Reject(Reject<'a>),
    /// Tag 5: the camera describes itself (answer to `Describe`).
    Description(Description),
    /// Tag 6: a line's pixels outside the lens field (inside a frame).
    #[serde(borrow)]
    Flags(LineFlags<'a>),
}

/// Whether `body`, which decodes to `value`, is `value`'s one encoding
/// (postcard's: shortest varints, nothing after the last field). Its length
/// tells: an over-long varint or a trailing byte only ever lengthens a
/// body, and every other field decodes from exactly its canonical bytes.
pub fn is_canonical<T: Serialize + ?Sized>(value: &T, body: &[u8]) -> bool {
    postcard::serialize_with_flavor::<_, postcard::ser_flavors::Size, usize>(value, Default::default())
        .is_ok_and(|n| n == body.len())
}

/// `d` updated with `bytes`: one out-of-line copy of the table loop for a
/// line's bytes and a message's slices (the M0 build inlined it in each:
/// 3.1 KB of flash, for 2 instructions a pixel more in its streaming of the
/// standard scene, `host-sim profile --board microbit`'s link row). A
/// single byte's stays in line. In line on the other boards (out of line
/// it cost the M3 48 B).
#[cfg_attr(hilcam_m0, inline(never))]
#[cfg_attr(not(hilcam_m0), inline(always))]
pub(crate) fn crc_update(d: &mut crc::Digest<'static, u32>, bytes: &[u8]) {
    d.update(bytes);
}

/// Checks a received message (COBS-decoded, without its delimiter): its
/// trailing CRC-32 and that the body before it is at least one byte long.
/// Returns the body.
pub fn check_crc(decoded: &[u8]) -> Option<&[u8]> {
    let split = decoded.len().checked_sub(4)?;
    let (body, crc) = decoded.split_at(split);
    (CRC32.checksum(body).to_le_bytes() == crc).then_some(body)
}

/// The largest encoded request a camera must accept, bytes (COBS, CRC and
/// delimiter included): the receiver buffer the shipped cameras use. The
/// largest requests (`SetPose`, 12 f64; `LoadScene` with
/// [`MAX_SCENE_CHUNK`] bytes) encode to at most 116 bytes.
pub const MAX_REQUEST: usize = 128;

/// The largest frame a receiver takes, pixel bytes (`width × height ×
/// bytes per pixel`): 16 MiB. A camera refuses a scene whose frames are
/// larger (`Unsupported`, `camera.height`).
pub const MAX_FRAME_BYTES: usize = 1 << 24;

/// Most scene bytes one `LoadScene` carries.
pub const MAX_SCENE_CHUNK: usize = 96;

/// Longest field name a [`Reject`] carries, bytes
/// (`primitives[15].checker.u_axis` is 29).
pub const FIELD_MAX: usize = 40;

/// Most frames one `Trigger` may ask for, and most frames pending at once.
pub const MAX_PENDING: u32 = 65_535;

/// A command with its envelope.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Request<'a> {
    /// [`PROTOCOL_VERSION`]; a camera refuses any other.
    pub version: u8,
    /// Sequence number: a camera applies a command only if it follows the
    /// last one it processed (`seq = last + 1`, wrapping; any value for the
    /// first), answers a repeat of the last one (the same number and the
    /// same command) again, with the same bytes, without applying it, and
    /// refuses anything else ([`Reason::OutOfOrder`]). `Describe` is
    /// answered whatever its number and does not count.
    pub seq: u32,
    /// What to do.
    #[serde(borrow)]
    pub command: Command<'a>,
}

/// What a host asks of a camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Command<'a> {
    /// Tag 0: answer with a [`Description`].
    Describe,
    /// Tag 1: the pose of the next frames: `R` (rows: the camera's axes in
    /// world coordinates, orthonormal within 10⁻⁶, det +1) and `T` (the
    /// centre of projection, metres, within ±1000 m per coordinate),
    /// camera-model.md §1.
    SetPose {
        /// `R`, row by row.
        rotation: [[f64; 3]; 3],
        /// `T`, metres.
        translation: [f64; 3],
    },
    /// Tag 2: the exposure `K`, DN per W/m² (0 to 10⁹).
    SetExposure {
        /// `K`.
        k: f64,
    },
    /// Tag 3: free-running or triggered.
    SetMode(Mode),
    /// Tag 4: render `frames` more frames (1 to [`MAX_PENDING`]; triggered
    /// mode only).
    Trigger {
        /// How many.
        frames: u16,
    },
    /// Tag 5: show the camera's scene `id` (its pose, exposure and every
    /// other value as that scene gives them).
    SelectScene {
        /// The camera's scene number (`Description::scenes` of them).
        id: u32,
    },
    /// Tag 6: part of a scene to show: bytes `offset..offset + len` of a
    /// [`SceneData`](crate::scene::data::SceneData) encoding of `total` bytes (at most
    /// `Description::max_scene`), sent in order from offset 0, each at most
    /// [`MAX_SCENE_CHUNK`] bytes. Offset 0 starts a new scene (dropping one
    /// partly received); the part that completes it has the scene decoded,
    /// checked and shown (its id: `Description::scenes − 1`), or refused
    /// naming the field, the camera showing what it showed.
    LoadScene {
        /// The encoding's length, bytes.
        total: u16,
        /// Where these bytes go.
        offset: u16,
        /// The bytes.
        #[serde(borrow, with = "serde_bytes")]
        bytes: &'a [u8],
    },
}

/// When the camera renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Tag 0: a frame for each one a `Trigger` asked for (the mode a camera
    /// starts in).
    Triggered,
    /// Tag 1: a frame every `period_us` µs of the camera's time, or back to
    /// back if rendering takes longer (0: back to back).
    FreeRun {
        /// Frame period, µs.
        period_us: u32,
    },
}

/// A command was applied (or was a repeat of the last one applied).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ack {
    /// The command's sequence number.
    pub seq: u32,
    /// When the camera processed it, ns in its time base.
    pub timestamp_ns: u64,
}

/// A command was refused; nothing of it was applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Reject<'a> {
    /// The command's sequence number.
    pub seq: u32,
    /// Why.
    pub reason: Reason,
    /// The field at fault, as `docs/wire.md` names it (`""` if none).
    pub field: &'a str,
}

/// Why a command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reason {
    /// Tag 0: a protocol version the camera does not speak.
    Version {
        /// The version it speaks.
        speaks: u8,
    },
    /// Tag 1: not the next sequence number.
    OutOfOrder {
        /// The number the camera expects.
        expected: u32,
    },
    /// Tag 2: a value outside its valid range (`field` names it).
    Invalid,
    /// Tag 3: not possible in the current mode (`Trigger` while free-running).
    WrongMode,
    /// Tag 4: a valid scene this camera cannot render (wider than its line
    /// buffer, a field of view beyond the renderer's, a stage its build
    /// leaves out); `field` names the value.
    Unsupported,
}

/// What a camera is and does now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Description {
    /// [`PROTOCOL_VERSION`].
    pub version: u8,
    /// Scenes the camera holds (`SelectScene` ids 0 to `scenes − 1`).
    pub scenes: u32,
    /// The scene it shows.
    pub scene_id: u32,
    /// Frame size, pixels.
    pub width: u16,
    /// Frame size, pixels.
    pub height: u16,
    /// Pixel format.
    pub format: WireFormat,
    /// Its mode.
    pub mode: Mode,
    /// Frames promised and not yet begun (triggered mode).
    pub pending: u32,
    /// The last command it processed (the next must be this + 1).
    pub last_command: Option<u32>,
    /// The id its next frame will carry.
    pub next_frame: u32,
    /// The largest encoded request it accepts, bytes.
    pub max_request: u32,
    /// The largest scene encoding `LoadScene` accepts, bytes (0: none).
    pub max_scene: u32,
    /// Distortion-table entries its frame holds: it plans within that many
    /// ([`crate::planner::Budget::max_table_entries`]; fewer than 2: no
    /// table), and a host rendering its frames plans with the same.
    pub max_table: u32,
}
