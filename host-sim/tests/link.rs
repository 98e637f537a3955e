//! The link: encoder → decoder round trips, the decoder on arbitrary and
//! corrupted bytes, the fault campaign's targets, link efficiency, a real pty,
//! and the wire example of docs/wire.md.

use hilcam::link::{Encoder, FrameStart, LinkError, WireFormat, PROTOCOL_VERSION};
use hilcam::render::LineBuffers;
use host_sim::link::decoder::{Decoder, Frame};
use host_sim::link::sim::{inject, send_frames, Faults, Link, Recorder};
use host_sim::stream_cmd::{campaign, run, wire_example};
use proptest::prelude::*;
use std::path::Path;

fn header(width: u16, height: u16, format: WireFormat) -> FrameStart {
    FrameStart {
        version: PROTOCOL_VERSION,
        frame_id: 0,
        width,
        height,
        format,
        scene_id: 3,
        exposure: 1 << 32,
        truth: Default::default(),
    }
}

fn decode_all(bytes: &[u8]) -> (Vec<Frame>, Decoder) {
    let mut dec = Decoder::new(1 << 20, 1 << 24);
    let mut out = Vec::new();
    dec.push(bytes, &mut |f| out.push(f));
    (out, dec)
}

fn format() -> impl Strategy<Value = WireFormat> {
    prop_oneof![
        Just(WireFormat::Gray8),
        (9u8..=16).prop_map(|bits| WireFormat::Gray16 { bits }),
        Just(WireFormat::Rgb565)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, .. ProptestConfig::default() })]

    /// The encoder writes a message as it serializes it, a COBS block at a
    /// time: the bytes are those of the whole-message encoding, whatever the
    /// runs of zeros and non-zeros (blocks of exactly 254 bytes, payloads
    /// ending on a block boundary).
    #[test]
    fn streamed_encoding_is_the_whole_message_encoding(
        len in 0usize..1200,
        zero_every in prop_oneof![Just(0usize), 1usize..6, 250usize..260, 500usize..520],
        seed in any::<u64>(),
        id in any::<u32>(),
    ) {
        let payload: Vec<u8> = (0..len)
            .map(|i| if zero_every > 0 && i % zero_every == 0 { 0 } else { ((i as u64).wrapping_mul(seed | 1) >> 7) as u8 | 1 })
            .collect();
        let msg = (id, payload.as_slice());
        let mut whole = vec![0u8; hilcam::link::wire_size(len + 16)];
        let expected = hilcam::link::encode_message(&msg, &mut whole).expect("fits").to_vec();
        let mut rec = Recorder::default();
        let n = hilcam::link::write_encoded(&mut rec, &msg).expect("writes");
        prop_assert_eq!(n as usize, expected.len());
        prop_assert_eq!(&rec.bytes, &expected);
    }

    /// Any frame size, format, content and number of frames survives the
    /// trip exactly, fed to the decoder in arbitrary pieces.
    #[test]
    fn frames_round_trip(w in 1u16..200, h in 1u16..40, fmt in format(), n in 1u32..4, seed in any::<u64>(), piece in 1usize..5000) {
        let start = header(w, h, fmt);
        let base: Vec<u8> = (0..start.frame_bytes()).map(|i| (i as u64).wrapping_mul(seed | 1).rotate_left(7) as u8).collect();
        let sent = send_frames(&base, start, n, Some(42)).expect("encodes");
        let mut dec = Decoder::new(1 << 20, 1 << 24);
        let mut got = Vec::new();
        for p in sent.stream.chunks(piece) {
            dec.push(p, &mut |f| got.push(f));
        }
        prop_assert_eq!(got.len(), n as usize);
        for (f, (id, _, px)) in got.iter().zip(&sent.frames) {
            prop_assert_eq!(f.start.frame_id, *id);
            prop_assert_eq!(&f.pixels, px);
            prop_assert_eq!(f.end.cost, Some(42));
        }
        prop_assert_eq!(dec.stats.bad_crc + dec.stats.bad_cobs + dec.stats.orphans, 0);
    }

    /// Arbitrary bytes never make the decoder panic or deliver a frame.
    #[test]
    fn decoder_survives_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..4000)) {
        let (frames, _) = decode_all(&bytes);
        prop_assert!(frames.is_empty());
    }

    /// Random corruption of a valid stream (flips, overwrites, deletions,
    /// insertions, cut points): the decoder never panics and never delivers
    /// a frame whose bytes differ from what was sent under its id.
    #[test]
    fn corrupted_streams_never_yield_wrong_frames(
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0u8..4, any::<u8>()), 1..30),
        seed in any::<u64>(),
    ) {
        let start = header(40, 6, WireFormat::Gray8);
        let base: Vec<u8> = (0..240).map(|i| (i as u64 ^ seed) as u8).collect();
        let sent = send_frames(&base, start, 4, None).expect("encodes");
        let mut s = sent.stream.clone();
        for (at, op, v) in edits {
            if s.is_empty() { break; }
            let i = at.index(s.len());
            match op {
                0 => s[i] ^= 1 << (v % 8),
                1 => s[i] = v,
                2 => { s.remove(i); }
                _ => s.insert(i, v),
            }
        }
        let (frames, _) = decode_all(&s);
        for f in frames {
            let want = sent.frames.iter().find(|(id, _, _)| *id == f.start.frame_id);
            prop_assert!(want.is_some_and(|(_, _, px)| *px == f.pixels), "corrupted frame accepted");
        }
    }
}

/// The campaign's targets, on a tenth of the standard campaign (1 200
/// frames; `host-sim faults` runs all 12 000): no corrupted frame accepted,
/// no untouched frame lost, no intact message lost, efficiency ≥ 0.98.
#[test]
fn fault_campaign_meets_targets() {
    let standard = host_sim::scene_file::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/standard.toml"
    )))
    .expect("standard scene");
    let r = campaign(&standard, 0.1, &mut |_| {}).expect("runs");
    let t = r.totals;
    assert!(t.frames_sent >= 1200);
    assert!(
        t.frames_hit_by_faults > 100,
        "the faults must hit something: {}",
        t.frames_hit_by_faults
    );
    assert_eq!(t.corrupted_frames_accepted, 0);
    assert_eq!(t.intact_frames_lost, 0);
    assert_eq!(t.untouched_messages_lost, 0);
    assert!(r.link_efficiency >= 0.98, "efficiency {}", r.link_efficiency);
    assert!(t.frames_delivered_intact + t.frames_hit_by_faults >= t.frames_sent);
}

/// A link cut in the middle of a frame loses that frame (and what the cut
/// spans) but decoding resumes with the next frame.
#[test]
fn decoding_resumes_after_a_cut() {
    let start = header(160, 120, WireFormat::Gray8);
    let base = vec![7u8; start.frame_bytes()];
    let sent = send_frames(&base, start, 6, None).expect("encodes");
    let (_, (a, b), _) = sent.frames[2];
    let mut s = sent.stream[..a + (b - a) / 2].to_vec();
    s.extend_from_slice(&sent.stream[b - 10..]); // resume mid-message, near frame 2's end
    let (frames, dec) = decode_all(&s);
    let ids: Vec<u32> = frames.iter().map(|f| f.start.frame_id).collect();
    assert_eq!(ids, [0, 1, 3, 4, 5]);
    assert!(dec.stats.bad_crc + dec.stats.bad_cobs >= 1);
    // and the faults model: truncation of every message loses every frame
    let out = run(
        &base,
        start,
        6,
        &Faults {
            truncate: 1.0,
            ..Faults::default()
        },
    )
    .expect("runs")
    .outcome
    .counts;
    assert_eq!(out.frames_delivered_intact, 0);
    assert_eq!(out.corrupted_frames_accepted, 0);
    let clean = inject(&sent.stream, &sent.messages, &Faults::default());
    assert_eq!(clean.stream, sent.stream);
    assert!(clean.hits.is_empty());
}

/// Encoder misuse is a typed error, not a panic or a malformed stream.
#[test]
fn encoder_rejects_misuse() {
    let mut enc = Encoder::<Recorder, 64>::new(Recorder::default()).expect("ok");
    assert_eq!(enc.push_line(&[1, 2, 3]), Err(LinkError::Sequence));
    assert_eq!(
        enc.begin_frame(header(65, 1, WireFormat::Gray8)),
        Err(LinkError::LineTooLong)
    );
    enc.begin_frame(header(4, 2, WireFormat::Gray8)).expect("ok");
    assert_eq!(enc.push_line(&[1, 2, 3]), Err(LinkError::Sequence));
    enc.push_line(&[1, 2, 3, 4]).expect("ok");
    assert_eq!(enc.end_frame(None), Err(LinkError::Sequence));
    assert!(matches!(
        Encoder::<Recorder, 0>::new(Recorder::default()),
        Err(LinkError::BufferTooSmall)
    ));
    // A line rendered in place: no place or commit outside a frame, none
    // past its last line.
    let mut enc = Encoder::<Recorder, 64>::new(Recorder::default()).expect("ok");
    assert!(matches!(enc.next_line(), Err(LinkError::Sequence)));
    assert_eq!(enc.commit_line(), Err(LinkError::Sequence));
    enc.begin_frame(header(4, 1, WireFormat::Gray8)).expect("ok");
    enc.next_line().expect("a place").copy_from_slice(&[5, 6, 7, 8]);
    enc.commit_line().expect("ok");
    assert!(matches!(enc.next_line(), Err(LinkError::Sequence)));
    assert_eq!(enc.commit_line(), Err(LinkError::Sequence));
    enc.end_frame(None).expect("ok");
}

/// Link timing models.
#[test]
fn link_models() {
    assert_eq!(Link::parse("uart:115200"), Ok(Link::Uart { baud: 115_200 }));
    assert!(Link::parse("uart:0").is_err() && Link::parse("spi").is_err());
    assert!((Link::Uart { baud: 1_000_000 }.seconds(100_000) - 1.0).abs() < 1e-12);
    // 19 × 64 bytes per millisecond
    assert!((Link::UsbFs.seconds(19 * 64 * 1000) - 1.0).abs() < 1e-12);
    assert!(Faults::parse("ber=2").is_err() && Faults::parse("nope=1").is_err());
    assert_eq!(Faults::parse("ber=1e-5,seed=9").expect("ok").seed, 9);
}

/// The same decoder reads a real serial device: here a pty pair.
#[test]
fn decoder_reads_a_pty() {
    use std::io::Write;
    let (mut master, mut slave) = serialport::TTYPort::pair().expect("pty pair");
    let start = header(32, 8, WireFormat::Gray8);
    let base: Vec<u8> = (0..256).map(|i| i as u8).collect();
    let sent = send_frames(&base, start, 3, None).expect("encodes");
    let stream = sent.stream.clone();
    let writer = std::thread::spawn(move || {
        master.write_all(&stream).expect("write");
        master.flush().expect("flush");
        std::thread::sleep(std::time::Duration::from_millis(200));
        drop(master);
    });
    serialport::SerialPort::set_timeout(&mut slave, std::time::Duration::from_millis(50)).expect("timeout");
    let mut dec = Decoder::new(1 << 20, 1 << 24);
    let mut frames = Vec::new();
    let limits = host_sim::link::serial::Limits {
        frames: 3,
        idle: std::time::Duration::from_secs(5),
        deadline: std::time::Duration::from_secs(30),
    };
    let (got, ending) = host_sim::link::serial::read_frames(&mut slave, limits, &mut dec, &mut |f| {
        frames.push(f);
        Ok(())
    });
    writer.join().expect("writer");
    assert_eq!((got, ending), (3, host_sim::link::serial::Ending::Complete));
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[2].pixels, sent.frames[2].2);
}

/// docs/wire.md shows exactly what the encoder produces.
#[test]
fn wire_doc_example_is_current() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/wire.md"))
        .expect("docs/wire.md");
    let all = wire_example().expect("example") + &host_sim::stream_cmd::command_example().expect("commands");
    for line in all.lines() {
        assert!(doc.contains(line.trim_end()), "docs/wire.md lacks {line:?}");
    }
    // The example scene is one a camera takes.
    let data = postcard::to_stdvec(&host_sim::stream_cmd::example_scene_data()).expect("encodes");
    assert_eq!(data.len(), 263, "docs/wire.md says 263 bytes");
    hilcam::scene::data::load(&data).expect("the example scene loads");
}

/// A reader that ends (the sender hung up) ends the read with what came:
/// nothing already decoded is lost, and the ending says why.
#[test]
fn a_hangup_keeps_the_frames_already_decoded() {
    let start = header(8, 2, WireFormat::Gray8);
    let sent = send_frames(&[1u8; 16], start, 2, None).expect("encodes");
    let mut dec = Decoder::new(1 << 20, 1 << 24);
    let mut frames = Vec::new();
    let limits = host_sim::link::serial::Limits {
        frames: 5,
        idle: std::time::Duration::from_secs(5),
        deadline: std::time::Duration::from_secs(30),
    };
    let (got, ending) = host_sim::link::serial::read_frames(
        &mut std::io::Cursor::new(sent.stream),
        limits,
        &mut dec,
        &mut |f| {
            frames.push(f);
            Ok(())
        },
    );
    assert_eq!((got, ending), (2, host_sim::link::serial::Ending::Hangup));
    assert_eq!(frames.len(), 2);
}

/// The renderer feeds the link through its frame sink, timed by the
/// adapter: the frame decodes to the bytes rendered, its end carries the
/// cost the adapter measured (the time between the sink's calls, not the
/// sink's own), and a header that does not match the frame is refused.
#[test]
fn a_frame_streams_through_the_sink_with_its_measured_cost() {
    use hilcam::render::{FrameError, Timed};
    let r = host_sim::scene_file::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/standard.toml"
    )))
    .expect("standard scene");
    let (scene, _, frame, core) =
        host_sim::harness::core_render(&r, &hilcam::planner::Budget::default()).expect("renders");
    let (w, h) = frame.size();
    let start = FrameStart::of(9, 0, &scene, &frame.stages(), 0, None);
    let mut flags = vec![0u8; w as usize];
    // A clock that advances one tick a reading: the adapter reads it
    // before and after each sink call, so each call spans one tick (not
    // counted) and each gap between calls one tick (counted).
    let t = std::cell::Cell::new(0u64);
    let mut enc = Encoder::<Recorder, 2048>::new(Recorder::default()).expect("encoder");
    let cost = {
        let mut sink = Timed::new(
            hilcam::link::Stream { enc: &mut enc, start },
            || {
                t.set(t.get() + 1);
                t.get()
            },
            |ticks| ticks,
            5,
        );
        // No line buffer: the stream places each line in the encoder's
        // chunk, where it is rendered.
        frame
            .render(LineBuffers::new(&mut [], &mut flags), &mut sink)
            .expect("streams");
        sink.cost()
    };
    // begin, the first line's place and each line's placed end a lap of 1
    // tick; after a placed the clock is next read when the next place
    // returns (the gap renders nothing and is not timed, nor is the end's):
    // h + 2 ticks, plus the 5 given.
    assert_eq!(cost, h as u64 + 2 + 5);
    let (frames, _) = decode_all(&enc.into_inner().bytes);
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].pixels, core.pixels);
    assert_eq!(frames[0].end.cost, Some(cost));
    // A header of another size is refused before anything is sent.
    let mut enc = Encoder::<Recorder, 2048>::new(Recorder::default()).expect("encoder");
    let wrong = FrameStart {
        width: w + 1,
        ..start
    };
    let r = frame.render(
        LineBuffers::new(&mut [], &mut flags),
        &mut hilcam::link::Stream {
            enc: &mut enc,
            start: wrong,
        },
    );
    assert!(matches!(r, Err(FrameError::Sink(LinkError::Sequence))), "{r:?}");
    assert!(enc.into_inner().bytes.is_empty());
}

/// Rendering each line into the encoder's chunk (`Stream` places it) puts
/// on the wire the bytes that rendering into a line buffer and copying it
/// in (`push_line`, a sink that does not place) does, on every shipped
/// scene — chunks split alike, flags and CRC the same.
#[test]
fn placed_lines_send_the_bytes_copied_lines_do() {
    use hilcam::render::{FrameInfo, FrameSink};
    /// `Stream` without its place: each line copied in.
    struct Copying<'a>(hilcam::link::Stream<'a, Recorder, 2048>);
    impl FrameSink for Copying<'_> {
        type Error = LinkError<std::convert::Infallible>;
        fn begin(&mut self, info: &FrameInfo) -> Result<(), Self::Error> {
            self.0.begin(info)
        }
        fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error> {
            self.0.line(y, pixels, flags)
        }
        fn end(&mut self, cost: Option<u64>) -> Result<(), Self::Error> {
            self.0.end(cost)
        }
    }
    let scenes = host_sim::qemu::shipped_scenes().expect("scenes");
    assert!(scenes.len() >= 8, "{scenes:?}");
    for path in scenes {
        let r = host_sim::scene_file::load(&path).expect("scene");
        let (scene, _, frame, _) =
            host_sim::harness::core_render(&r, &hilcam::planner::Budget::default()).expect("renders");
        let start = FrameStart::of(3, 0, &scene, &frame.stages(), 0, None);
        let mut flags = vec![0u8; frame.size().0 as usize];
        let mut placed = Encoder::<Recorder, 2048>::new(Recorder::default()).expect("encoder");
        frame
            .render(
                LineBuffers::new(&mut [], &mut flags),
                &mut hilcam::link::Stream {
                    enc: &mut placed,
                    start,
                },
            )
            .expect("placed");
        let mut copied = Encoder::<Recorder, 2048>::new(Recorder::default()).expect("encoder");
        let mut line = vec![0u8; frame.line_bytes()];
        frame
            .render(
                LineBuffers::new(&mut line, &mut flags),
                &mut Copying(hilcam::link::Stream {
                    enc: &mut copied,
                    start,
                }),
            )
            .expect("copied");
        let (placed, copied) = (placed.into_inner().bytes, copied.into_inner().bytes);
        assert!(!placed.is_empty());
        assert!(placed == copied, "{}: the wire bytes differ", path.display());
    }
}

/// A message whose CRC is right but whose body is not the canonical
/// encoding of what it decodes to — bytes after the last field, an
/// over-long varint — is refused (`bad_message`), as docs/wire.md says;
/// the canonical body of the same message is accepted.
#[test]
fn non_canonical_bodies_are_refused() {
    let wire = |body: &[u8]| {
        let mut msg = body.to_vec();
        msg.extend_from_slice(&hilcam::link::CRC32.checksum(body).to_le_bytes());
        let mut bytes = vec![0u8; msg.len() + msg.len() / 254 + 2];
        let k = cobs::encode(&msg, &mut bytes);
        bytes.truncate(k);
        bytes.push(0);
        let mut dec = Decoder::new(1 << 20, 1 << 24);
        dec.push(&bytes, &mut |_| {});
        (dec.stats.messages_ok, dec.stats.bad_message)
    };
    let start = FrameStart {
        frame_id: 7,
        ..header(4, 2, WireFormat::Gray8)
    };
    let mut buf = [0u8; 512];
    let body = postcard::to_slice(&hilcam::link::Message::FrameStart(start), &mut buf)
        .expect("serializes")
        .to_vec();
    // tag 0, version, frame_id 7: the third byte.
    assert_eq!(&body[..3], &[0, PROTOCOL_VERSION, 7]);
    assert_eq!(wire(&body), (1, 0), "the canonical body");
    let mut trailing = body.clone();
    trailing.push(0);
    assert_eq!(wire(&trailing), (0, 1), "a trailing byte");
    let mut long = body[..2].to_vec();
    long.extend_from_slice(&[0x87, 0x00]); // 7 as a two-byte varint
    long.extend_from_slice(&body[3..]);
    assert_eq!(wire(&long), (0, 1), "an over-long varint");
}

/// A frame rendered and streamed as the firmware does it (the core's
/// `Stream` sink), decoded by the host.
fn streamed(scene_text: &str) -> (Vec<u8>, Vec<u8>, Recorder) {
    use hilcam::link::Stream;
    use hilcam::planner::{plan, Budget};
    use hilcam::render::Frame as Prepared;
    let r = host_sim::scene_file::parse(scene_text).expect("scene");
    let scene = r.core_scene().expect("core scene");
    let p = plan(&scene, &Budget::default());
    let frame = Prepared::new(&scene, &p.options).expect("prepares");
    let w = r.desc.camera.width as usize;
    let (mut line, mut flags) = (vec![0u8; w * 2], vec![0u8; w]);
    let mut enc = Encoder::<Recorder, 2048>::new(Recorder::default()).expect("encoder");
    let start = FrameStart::of(0, 0, &scene, &frame.stages(), 0, None);
    frame
        .render(
            LineBuffers::new(&mut line, &mut flags),
            &mut Stream { enc: &mut enc, start },
        )
        .expect("renders");
    let host = host_sim::harness::planned_frame(&scene, "s", &hilcam::planner::Budget::default(), 0)
        .expect("host render")
        .0;
    (host.pixels, host.flags, enc.into_inner())
}

fn standard_text() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/standard.toml")).expect("read")
}

/// A frame with pixels beyond the distortion's fold carries them: its
/// Flags messages give exactly the renderer's out-of-field pixels, the
/// FrameEnd their count; a lost Flags message drops the frame rather than
/// deliver it without them. A frame without such pixels sends none.
#[test]
fn out_of_field_flags_travel_with_the_frame() {
    let folded = standard_text().replace("distortion = [0.15, 0.05]", "distortion = [-2.0, 0.0]");
    let (pixels, flags, rec) = streamed(&folded);
    let (frames, dec) = decode_all(&rec.bytes);
    assert_eq!(frames.len(), 1, "{:?}", dec.stats);
    let f = &frames[0];
    assert_eq!(f.pixels, pixels);
    let outside = flags
        .iter()
        .filter(|b| **b & hilcam::render::FLAG_OUTSIDE_FIELD != 0)
        .count();
    assert!(outside > 1000, "the fold lies inside the sensor: {outside}");
    assert_eq!(f.end.outside as usize, outside);
    assert_eq!(f.flags, host_sim::link::decoder::wire_flags(&flags));
    // Lose one Flags message (tag 6 after COBS: the message's second byte).
    let flag_msgs: Vec<usize> = rec
        .writes
        .iter()
        .enumerate()
        .filter(|(_, (a, b))| b - a > 2 && rec.bytes[a + 1] == 6)
        .map(|(k, _)| k)
        .collect();
    assert!(flag_msgs.len() > 10, "{} lines flagged", flag_msgs.len());
    let (a, b) = rec.writes[flag_msgs[3]];
    let mut lost = rec.bytes[..a].to_vec();
    lost.extend_from_slice(&rec.bytes[b..]);
    let (frames, dec) = decode_all(&lost);
    assert!(frames.is_empty());
    assert_eq!(dec.stats.frames_dropped_flags, 1);
    // The shipped standard scene has no such pixels: no Flags message.
    let (_, flags, rec) = streamed(&standard_text());
    assert!(flags.iter().all(|b| *b == 0));
    assert!(rec
        .writes
        .iter()
        .all(|(a, b)| b - a <= 2 || rec.bytes[a + 1] != 6));
    let (frames, _) = decode_all(&rec.bytes);
    assert_eq!(
        (frames.len(), frames[0].end.outside, frames[0].flags.len()),
        (1, 0, 0)
    );
}

/// A Gray16 value of `2^bits` or more drops the frame (docs/wire.md,
/// "Receiving"): counted, never delivered wrapped or clipped.
#[test]
fn a_gray16_value_beyond_its_bits_drops_the_frame() {
    let start = header(4, 2, WireFormat::Gray16 { bits: 12 });
    let encode = |px: &[u8]| {
        let mut enc = Encoder::<host_sim::link::sim::Recorder, 64>::new(Default::default()).expect("encoder");
        enc.begin_frame(start).expect("start");
        for l in px.chunks_exact(start.line_bytes()) {
            enc.push_line(l).expect("line");
        }
        enc.end_frame(None).expect("end");
        enc.into_inner().bytes
    };
    let mut px = [0xff, 0x0f].repeat(8);
    assert_eq!(decode_all(&encode(&px)).0.len(), 1);
    px[6..8].copy_from_slice(&0x1000u16.to_le_bytes());
    let (got, dec) = decode_all(&encode(&px));
    assert!(got.is_empty());
    assert_eq!((dec.stats.frames_dropped_value, dec.stats.frames_lost()), (1, 1));
}

/// A capture that ends inside a frame counts it as cut.
#[test]
fn a_frame_cut_off_by_the_end_of_the_input_is_counted() {
    let start = header(8, 4, WireFormat::Gray8);
    let sent = send_frames(&[7u8; 32], start, 1, None).expect("encodes");
    let cut = &sent.stream[..sent.stream.len() - 10];
    let (got, mut dec) = decode_all(cut);
    assert!(got.is_empty());
    assert!(dec.finish());
    assert_eq!((dec.stats.frames_cut, dec.stats.frames_lost()), (1, 1));
    assert!(!dec.finish(), "counted once");
}

/// A line's `Flags` message twice drops the frame, even where the end's
/// count agrees (a sender that counted both): flags are never merged.
#[test]
fn a_line_flagged_twice_drops_the_frame() {
    let start = header(8, 2, WireFormat::Gray8);
    let flags = [hilcam::render::FLAG_OUTSIDE_FIELD, 0, 0, 0, 0, 0, 0, 0];
    let encode = |twice: bool| {
        let mut enc = Encoder::<host_sim::link::sim::Recorder, 64>::new(Default::default()).expect("encoder");
        enc.begin_frame(start).expect("start");
        for _ in 0..2 {
            enc.push_line(&[9; 8]).expect("line");
            enc.push_flags(&flags).expect("flags");
            if twice {
                enc.push_flags(&flags).expect("flags again");
            }
        }
        enc.end_frame(None).expect("end");
        enc.into_inner().bytes
    };
    let (got, _) = decode_all(&encode(false));
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].flags.iter().filter(|f| **f != 0).count(), 2);
    let (got, dec) = decode_all(&encode(true));
    assert!(got.is_empty());
    assert_eq!(dec.stats.frames_dropped_flags, 1);
}
