//! `host-sim stream`, `host-sim faults` and the wire example: frames rendered
//! by the core, encoded by the core's encoder, sent through a simulated link
//! with faults, decoded by the host decoder, and checked byte for byte.

use crate::link::decoder::{Decoder, Stats};
use crate::link::sim::{frame_pixels, Channel, Faults, Link, Recorder, HOST_CHUNK};
use crate::scene_file::Resolved;
use hilcam::link::{Encoder, FrameStart, Truth, WireFormat, WirePlan, PROTOCOL_VERSION};
use hilcam::planner::Budget;
use serde::Serialize;

/// The core's render of a scene: pixel bytes and the frame header to send
/// them with.
pub fn core_frame(r: &Resolved, scene_id: u32) -> Result<(Vec<u8>, FrameStart), String> {
    let (scene, _, frame, core) = crate::harness::core_render(r, &Budget::default())?;
    let start = FrameStart::of(0, scene_id, &scene, &frame.stages(), 0, None);
    Ok((core.pixels, start))
}

/// Whether the link carries the scene's frames, checked before anything
/// is rendered: a line within the encoder's chunk ([`HOST_CHUNK`] bytes, as
/// the host camera sends it) and a frame within
/// [`hilcam::link::MAX_FRAME_BYTES`], the most a receiver takes. So a
/// stream's memory is bounded by that cap, whatever the scene asks.
pub fn link_carries(r: &Resolved) -> Result<(), String> {
    let c = &r.desc.camera;
    let bpp = r.format.bytes_per_pixel();
    let line = c.width as usize * bpp;
    if line > HOST_CHUNK {
        return Err(format!(
            "camera.width: {} pixels of {} make a line of {line} B; the link carries lines of at most {HOST_CHUNK} B ({} pixels)",
            c.width,
            r.format.name(),
            HOST_CHUNK / bpp
        ));
    }
    let frame = line as u64 * u64::from(c.height);
    if frame > hilcam::link::MAX_FRAME_BYTES as u64 {
        return Err(format!(
            "camera.height: a {}x{} {} frame is {frame} B; the link carries frames of at most {} B",
            c.width,
            c.height,
            r.format.name(),
            hilcam::link::MAX_FRAME_BYTES
        ));
    }
    Ok(())
}

/// What happened to the frames and messages sent through a link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    /// Frames sent.
    pub frames_sent: u64,
    /// Frames any fault touched (a byte of theirs, from the leading
    /// delimiter to the end message's delimiter).
    pub frames_hit_by_faults: u64,
    /// Frames delivered with exactly the bytes sent.
    pub frames_delivered_intact: u64,
    /// Frames delivered whose bytes differ from what was sent under that id
    /// (must be 0).
    pub corrupted_frames_accepted: u64,
    /// Frames no fault touched that were not delivered (must be 0).
    pub intact_frames_lost: u64,
    /// Messages no fault touched, neither their bytes nor the delimiter
    /// before them (the intact messages).
    pub untouched_messages: u64,
    /// Intact messages that did not decode (must be 0: decoding resumes at
    /// the first intact message after a fault).
    pub untouched_messages_lost: u64,
}

impl std::ops::AddAssign for Counts {
    fn add_assign(&mut self, o: Counts) {
        self.frames_sent += o.frames_sent;
        self.frames_hit_by_faults += o.frames_hit_by_faults;
        self.frames_delivered_intact += o.frames_delivered_intact;
        self.corrupted_frames_accepted += o.corrupted_frames_accepted;
        self.intact_frames_lost += o.intact_frames_lost;
        self.untouched_messages += o.untouched_messages;
        self.untouched_messages_lost += o.untouched_messages_lost;
    }
}

/// The outcome of sending frames through a link.
#[derive(Clone, Debug, Serialize)]
pub struct Outcome {
    /// Fault settings.
    pub faults: Faults,
    /// What happened.
    #[serde(flatten)]
    pub counts: Counts,
    /// The decoder's counts.
    pub decoder: Stats,
}

/// What [`run`] sent and what came out.
pub struct Run {
    /// What happened.
    pub outcome: Outcome,
    /// Bytes on the wire (without faults).
    pub wire_bytes: u64,
    /// Pixel payload bytes.
    pub pixel_bytes: u64,
    /// The first frame delivered intact: its id and pixels.
    pub first_delivered: Option<(u32, Vec<u8>)>,
}

/// Encodes `n` frames of `base` ([`frame_pixels`]: each distinct) with the
/// core's encoder, sends them through a link with `faults`, decodes, and
/// checks every frame and message against what was sent. A frame at a
/// time: memory does not grow with `n`.
pub fn run(base: &[u8], start: FrameStart, n: u32, faults: &Faults) -> Result<Run, String> {
    let mut enc =
        Encoder::<Recorder, HOST_CHUNK>::new(Recorder::default()).map_err(|e| format!("encoder: {e:?}"))?;
    let mut channel = Channel::new(faults);
    // Each sent message's identity: the CRC-32 of its body, from a clean
    // decode of the sent bytes (in order, one per non-empty message).
    let mut clean = Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES);
    clean.record = true;
    let mut dec = Decoder::new(1 << 20, hilcam::link::MAX_FRAME_BYTES);
    dec.record = true;
    let (mut wire, mut c) = (0u64, Counts::default());
    let (mut out, mut hits) = (Vec::new(), Vec::new());
    let mut first_delivered = None;
    let line = start.line_bytes();
    for k in 0..n {
        let pixels = frame_pixels(base, line, k, start.format);
        let rec = enc.writer();
        rec.clear();
        enc.begin_frame(FrameStart { frame_id: k, ..start })
            .map_err(|e| format!("encoder: {e:?}"))?;
        for l in pixels.chunks_exact(line) {
            enc.push_line(l).map_err(|e| format!("encoder: {e:?}"))?;
        }
        enc.end_frame(None).map_err(|e| format!("encoder: {e:?}"))?;
        let rec = enc.writer();
        let at = wire as usize;
        clean.received.clear();
        clean.push(&rec.bytes, &mut |_| {});
        out.clear();
        // Keep the hit on the delimiter before this frame (it counts for
        // the first message's intactness).
        hits.retain(|h| *h + 1 >= at);
        channel.send(&rec.bytes, &rec.writes, &mut out, &mut hits);
        dec.received.clear();
        let mut delivered = false;
        let mut first = first_delivered.is_none();
        dec.push(&out, &mut |f| {
            if f.start.frame_id == k && !delivered && f.pixels == pixels {
                delivered = true;
                if first {
                    first_delivered = Some((k, f.pixels));
                    first = false;
                }
            } else {
                c.corrupted_frames_accepted += 1;
            }
        });
        let touched = |(a, b): (usize, usize)| {
            let i = hits.partition_point(|h| *h < a);
            hits.get(i).is_some_and(|h| *h < b)
        };
        let hit = touched((at, at + rec.bytes.len()));
        c.frames_sent += 1;
        c.frames_hit_by_faults += hit as u64;
        c.frames_delivered_intact += delivered as u64;
        c.intact_frames_lost += (!hit && !delivered) as u64;
        let bodies = rec
            .writes
            .iter()
            .filter(|(a, b)| b - a > 1)
            .zip(clean.received.iter());
        for ((a, b), id) in bodies {
            // intact: its bytes and the delimiter before it
            if !touched(((at + a).saturating_sub(1), at + b)) {
                c.untouched_messages += 1;
                c.untouched_messages_lost += (!dec.received.contains(id)) as u64;
            }
        }
        wire += rec.bytes.len() as u64;
    }
    Ok(Run {
        outcome: Outcome {
            faults: *faults,
            counts: c,
            decoder: dec.stats,
        },
        wire_bytes: wire,
        pixel_bytes: enc.pixel_bytes,
        first_delivered,
    })
}

/// `stream.json`.
#[derive(Clone, Debug, Serialize)]
pub struct StreamReport {
    /// Scene name.
    pub scene: String,
    /// Link.
    pub link: String,
    /// Frame size and format.
    pub width: u16,
    /// Frame size and format.
    pub height: u16,
    /// Frame size and format.
    pub format: String,
    /// Chunk buffer of the encoder, bytes.
    pub chunk_bytes: usize,
    /// Pixel bytes per frame.
    pub frame_bytes: usize,
    /// Bytes on the wire per frame (without faults).
    pub wire_bytes_per_frame: f64,
    /// Pixel payload bytes / bytes on the wire.
    pub link_efficiency: f64,
    /// Time a frame takes on the link, s.
    pub seconds_per_frame: f64,
    /// Frames per second the link carries.
    pub achievable_fps: f64,
    /// What happened to the frames.
    pub outcome: Outcome,
    /// The frame `received.png` shows: the first delivered intact (none:
    /// no frame arrived, and no `received.png` is written).
    pub received_png_frame: Option<u32>,
}

/// Renders, encodes `frames` frames, sends them through `link` with
/// `faults`, decodes, and reports. Also returns the first frame delivered
/// intact, as the receiver decoded it.
pub fn stream(
    r: &Resolved,
    link: Link,
    faults: &Faults,
    frames: u32,
) -> Result<(StreamReport, Option<Vec<u8>>), String> {
    link_carries(r)?;
    let (pixels, start) = core_frame(r, 0)?;
    let sent = run(&pixels, start, frames, faults)?;
    let (received_png_frame, first) = sent.first_delivered.map_or((None, None), |(k, p)| (Some(k), Some(p)));
    let wire_per_frame = sent.wire_bytes as f64 / frames.max(1) as f64;
    let secs = link.seconds(wire_per_frame.ceil() as u64);
    Ok((
        StreamReport {
            scene: r.desc.name.clone(),
            link: link.name(),
            width: start.width,
            height: start.height,
            format: r.format.name().into(),
            chunk_bytes: crate::link::sim::HOST_CHUNK,
            frame_bytes: start.frame_bytes(),
            wire_bytes_per_frame: wire_per_frame,
            link_efficiency: sent.pixel_bytes as f64 / sent.wire_bytes as f64,
            seconds_per_frame: secs,
            achievable_fps: 1.0 / secs,
            outcome: sent.outcome,
            received_png_frame,
        },
        first,
    ))
}

/// One setting of the campaign.
#[derive(Clone, Debug, Serialize)]
pub struct Setting {
    /// Name.
    pub name: String,
    /// Outcome.
    #[serde(flatten)]
    pub outcome: Outcome,
}

/// `faults.json`.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignReport {
    /// Totals over all settings.
    #[serde(flatten)]
    pub totals: Counts,
    /// Pixel payload bytes / bytes on the wire, 160×120 Gray8, no faults.
    pub link_efficiency: f64,
    /// The frames: scene, size, format, chunk buffer.
    pub frame: String,
    /// Per setting.
    pub settings: Vec<Setting>,
}

/// The standard campaign: 12 000 frames of the standard scene (160×120
/// Gray8), each frame distinct, through bit-error rates from 10⁻⁶ to 10⁻³,
/// drops, duplicates, inserts, truncations, cuts, and a mix.
pub fn campaign(
    standard: &Resolved,
    scale: f64,
    progress: &mut dyn FnMut(&str),
) -> Result<CampaignReport, String> {
    let (pixels, start) = core_frame(standard, 0)?;
    let f = |ber, drop, dup, insert, truncate, cut, seed| Faults {
        ber,
        drop,
        dup,
        insert,
        truncate,
        cut,
        seed,
    };
    let plan: Vec<(&str, u32, Faults)> = vec![
        ("ber-1e-6", 2000, f(1e-6, 0.0, 0.0, 0.0, 0.0, 0.0, 1)),
        ("ber-1e-5", 2000, f(1e-5, 0.0, 0.0, 0.0, 0.0, 0.0, 2)),
        ("ber-1e-4", 1500, f(1e-4, 0.0, 0.0, 0.0, 0.0, 0.0, 3)),
        ("ber-1e-3", 500, f(1e-3, 0.0, 0.0, 0.0, 0.0, 0.0, 4)),
        ("drop-1e-5", 1000, f(0.0, 1e-5, 0.0, 0.0, 0.0, 0.0, 5)),
        ("dup-1e-5", 1000, f(0.0, 0.0, 1e-5, 0.0, 0.0, 0.0, 6)),
        ("insert-1e-5", 1000, f(0.0, 0.0, 0.0, 1e-5, 0.0, 0.0, 7)),
        ("truncate-0.01", 1000, f(0.0, 0.0, 0.0, 0.0, 0.01, 0.0, 8)),
        ("cut-0.002", 1000, f(0.0, 0.0, 0.0, 0.0, 0.0, 0.002, 9)),
        ("mixed", 1000, f(1e-5, 1e-6, 1e-6, 1e-6, 0.002, 0.0005, 10)),
    ];
    let clean = run(&pixels, start, 10, &Faults::default())?;
    let efficiency = clean.pixel_bytes as f64 / clean.wire_bytes as f64;
    let mut settings = Vec::new();
    for (name, n, faults) in plan {
        let n = ((n as f64 * scale).ceil() as u32).max(1);
        progress(name);
        settings.push(Setting {
            name: name.into(),
            outcome: run(&pixels, start, n, &faults)?.outcome,
        });
    }
    let mut totals = Counts::default();
    for st in &settings {
        totals += st.outcome.counts;
    }
    Ok(CampaignReport {
        totals,
        link_efficiency: efficiency,
        frame: format!(
            "{} {}x{} {} chunk {} B",
            standard.desc.name,
            start.width,
            start.height,
            standard.format.name(),
            crate::link::sim::HOST_CHUNK
        ),
        settings,
    })
}

/// The ground truth of `docs/wire.md`'s example frame: a camera at
/// (0, 0, −1) m looking along world +z, f = 4 mm, 5 µm pixels, principal
/// point (1.5, 0.5), no distortion, rendered fast through a pinhole, 1 ms
/// after the camera started, command 3 the last processed.
fn example_truth() -> Truth {
    Truth {
        timestamp_ns: 1_000_000,
        command: Some(3),
        rotation: [[1 << 62, 0, 0], [0, 1 << 62, 0], [0, 0, 1 << 62]],
        translation: [0, 0, -(1 << 40)],
        focal_length: hilcam::num::Len::from_num(0.004).to_bits(),
        pitch: [hilcam::num::Pitch::from_num(5e-6).to_bits(); 2],
        principal_point: [3 << 15, 1 << 15],
        distortion: [0, 0],
        lens: [hilcam::num::Len::from_num(0.002).to_bits(), 3 << 40],
        model_scale: 0,
        plan: WirePlan {
            samples: 1,
            ..WirePlan::default()
        },
    }
}

/// A complete small frame on the wire (4×2 Gray8), as annotated hex: the
/// example `docs/wire.md` shows.
pub fn wire_example() -> Result<String, String> {
    use hilcam::render::FLAG_OUTSIDE_FIELD;
    let start = FrameStart {
        version: PROTOCOL_VERSION,
        frame_id: 7,
        width: 4,
        height: 2,
        format: WireFormat::Gray8,
        scene_id: 1,
        exposure: 800i64 << 32,
        truth: example_truth(),
    };
    // Line 1's last two pixels lie outside the lens field (value 0).
    let pixels = [0x00, 0x01, 0x7f, 0x80, 0xff, 0x10, 0x00, 0x00];
    let flags = [0, 0, 0, 0, 0, 0, FLAG_OUTSIDE_FIELD, FLAG_OUTSIDE_FIELD];
    let mut enc =
        hilcam::link::Encoder::<crate::link::sim::Recorder, 8>::new(crate::link::sim::Recorder::default())
            .map_err(|e| format!("{e:?}"))?;
    enc.begin_frame(start).map_err(|e| format!("{e:?}"))?;
    for (l, f) in pixels.chunks(4).zip(flags.chunks(4)) {
        enc.push_line(l).map_err(|e| format!("{e:?}"))?;
        enc.push_flags(f).map_err(|e| format!("{e:?}"))?;
    }
    enc.end_frame(Some(1234)).map_err(|e| format!("{e:?}"))?;
    let rec = enc.into_inner();
    let names = ["delimiter", "FrameStart", "Flags", "Chunk", "FrameEnd"];
    let mut s = String::new();
    for (k, (a, b)) in rec.writes.iter().enumerate() {
        hex_lines(&mut s, names.get(k).unwrap_or(&"?"), &rec.bytes[*a..*b]);
    }
    Ok(s)
}

/// The scene of `docs/wire.md`'s scene-data example: a 4×3 Gray8 camera
/// 1 m in front of a gray sphere lit from the camera's side.
pub fn example_scene_data() -> hilcam::scene::data::SceneData {
    use hilcam::scene::ShapeSpec;
    use hilcam::scene::data::{
        CameraData, Colour, FormatData, LightData, MaterialData, PrimitiveData, SceneData,
    };
    let mut d = SceneData {
        camera: CameraData {
            width: 4,
            height: 3,
            focal_length: 0.004,
            pitch: [1e-5, 1e-5],
            principal_point: None,
            orthographic_scale: None,
            aperture: hilcam::Aperture::FNumber(2.0),
            focus_distance: 1.0,
            tolerable_blur: 1e-5,
            distortion: None,
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            position: [0.0, 0.0, -1.0],
        },
        format: FormatData::Gray8,
        exposure: 800.0,
        ambient: Colour::Gray(0.0),
        background: Colour::Gray(0.5),
        materials: heapless::Vec::new(),
        primitives: heapless::Vec::new(),
        lights: heapless::Vec::new(),
        sampling: None,
        noise: None,
        lens: None,
        shadows: true,
    };
    let _ = d.materials.push(MaterialData {
        albedo: Colour::Gray(0.5),
        specular: None,
    });
    let _ = d.primitives.push(PrimitiveData {
        shape: ShapeSpec::Sphere {
            centre: [0.0; 3],
            radius: 0.25,
        },
        material: 0,
        checker: None,
    });
    let _ = d.lights.push(LightData::Directional {
        direction: [0.0, 0.0, -1.0],
        irradiance: Colour::Gray(1000.0),
    });
    d
}

/// The commands and answers of `docs/wire.md`'s examples, as annotated
/// hex: a `SetPose`, a `Trigger` and a `Describe` (host → camera), then an
/// `Ack`, a `Reject` and a `Description` (camera → host).
pub fn command_example() -> Result<String, String> {
    use hilcam::link::{Ack, Command, Description, Mode, Reason, Reject, Request};
    let mut s = String::new();
    let mut buf = [0u8; 256];
    let req = |seq, command| Request {
        version: PROTOCOL_VERSION,
        seq,
        command,
    };
    let requests = [
        (
            "SetPose",
            req(
                4,
                Command::SetPose {
                    rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                    translation: [0.5, 0.0, -2.0],
                },
            ),
        ),
        ("Trigger", req(5, Command::Trigger { frames: 1 })),
        ("Describe", req(6, Command::Describe)),
    ];
    for (name, r) in requests {
        let bytes = hilcam::link::encode_message(&r, &mut buf).ok_or("encode")?;
        hex_lines(&mut s, name, bytes);
    }
    // A scene sent as data in LoadScene parts of at most MAX_SCENE_CHUNK.
    let scene = example_scene_data();
    let data = postcard::to_stdvec(&scene).map_err(|e| e.to_string())?;
    hex_lines(&mut s, "SceneData", &data);
    let parts = data.chunks(hilcam::link::MAX_SCENE_CHUNK);
    for (k, part) in (0u32..).zip(parts) {
        let r = req(
            7 + k,
            Command::LoadScene {
                total: data.len() as u16,
                offset: (k as usize * hilcam::link::MAX_SCENE_CHUNK) as u16,
                bytes: part,
            },
        );
        let bytes = hilcam::link::encode_message(&r, &mut buf).ok_or("encode")?;
        hex_lines(&mut s, "LoadScene", bytes);
    }
    let mut enc = Encoder::<Recorder, 8>::new(Recorder::default()).map_err(|e| format!("{e:?}"))?;
    enc.send_reply(&Ack {
        seq: 5,
        timestamp_ns: 2_000_000,
    })
    .map_err(|e| format!("{e:?}"))?;
    enc.send_reply(&Reject {
        seq: 6,
        reason: Reason::OutOfOrder { expected: 5 },
        field: "seq",
    })
    .map_err(|e| format!("{e:?}"))?;
    enc.send_reply(&Description {
        version: PROTOCOL_VERSION,
        scenes: 8,
        scene_id: 0,
        width: 160,
        height: 120,
        format: WireFormat::Gray8,
        mode: Mode::Triggered,
        pending: 0,
        last_command: Some(5),
        next_frame: 1,
        max_request: hilcam::link::MAX_REQUEST as u32,
        max_scene: hilcam::scene::data::MAX_SCENE_DATA as u32,
        max_table: hilcam::geom::distortion::MAX_LUT as u32,
    })
    .map_err(|e| format!("{e:?}"))?;
    let rec = enc.into_inner();
    for (name, (a, b)) in ["Ack", "Reject", "Description"].iter().zip(&rec.writes) {
        hex_lines(&mut s, name, &rec.bytes[*a..*b]);
    }
    Ok(s)
}

/// `name` and `bytes` in hex, 24 bytes a line.
fn hex_lines(s: &mut String, name: &str, bytes: &[u8]) {
    use std::fmt::Write;
    for (i, piece) in bytes.chunks(24).enumerate() {
        let hex: Vec<String> = piece.iter().map(|x| format!("{x:02x}")).collect();
        let label = if i == 0 { name } else { "" };
        let _ = writeln!(s, "{label:<11} {}", hex.join(" "));
    }
}
