//! The host → camera direction: the receiver on arbitrary, corrupted,
//! oversized and non-canonical bytes; the sequence rule (no command applied
//! twice or out of order); refused commands leave the camera's last good
//! state; the reply messages' bytes.

use hilcam::link::control::{Answer, Control, Fault, Library, Receiver, RxError};
use hilcam::link::{encode_message, Encoder, Message, CRC32, PROTOCOL_VERSION};
use hilcam::link::{
    Ack, Command, Description, Mode, Reason, Reject, Request, FIELD_MAX, MAX_PENDING, MAX_REQUEST,
    MAX_SCENE_CHUNK,
};
use hilcam::scene::data::MAX_SCENE_DATA;
use hilcam::scene::Scene;
use proptest::prelude::*;
use std::path::Path;

fn resolved(name: &str) -> host_sim::scene_file::Resolved {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    host_sim::scene_file::load(&p).expect("scene")
}

fn standard() -> Scene {
    resolved("standard.toml").core_scene().expect("core scene")
}

fn standard_bytes() -> Vec<u8> {
    resolved("standard.toml").scene_bytes().expect("scene data")
}

fn wire(req: &Request) -> Vec<u8> {
    let mut buf = [0u8; MAX_REQUEST];
    encode_message(req, &mut buf).expect("fits MAX_REQUEST").to_vec()
}

fn request(seq: u32, command: Command) -> Request {
    Request {
        version: PROTOCOL_VERSION,
        seq,
        command,
    }
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// What the receiver made of `bytes`: each request as its encoding (a
/// request borrows the receiver's buffer until the next byte).
fn feed<const N: usize>(rx: &mut Receiver<N>, bytes: &[u8]) -> Vec<Result<Vec<u8>, RxError>> {
    bytes
        .iter()
        .filter_map(|b| rx.push(*b).map(|r| r.map(|req| wire(&req))))
        .collect()
}

fn any_command() -> impl Strategy<Value = Command<'static>> {
    let f = -2.0f64..2.0;
    prop_oneof![
        Just(Command::Describe),
        (
            proptest::array::uniform9(f.clone()),
            proptest::array::uniform3(f.clone())
        )
            .prop_map(|(r, t)| {
                Command::SetPose {
                    rotation: [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]],
                    translation: t,
                }
            }),
        any::<f64>().prop_map(|k| Command::SetExposure { k }),
        any::<u32>().prop_map(|period_us| Command::SetMode(Mode::FreeRun { period_us })),
        Just(Command::SetMode(Mode::Triggered)),
        any::<u16>().prop_map(|frames| Command::Trigger { frames }),
        any::<u32>().prop_map(|id| Command::SelectScene { id }),
        (
            any::<u16>(),
            any::<u16>(),
            proptest::collection::vec(any::<u8>(), 0..=MAX_SCENE_CHUNK)
        )
            .prop_map(|(total, offset, v)| Command::LoadScene {
                total,
                offset,
                bytes: Box::leak(v.into_boxed_slice()),
            }),
    ]
}

/// The largest request, with every float at full width, fits MAX_REQUEST.
#[test]
fn the_largest_request_fits_the_receiver() {
    let worst = request(
        u32::MAX,
        Command::SetPose {
            rotation: [[f64::MIN; 3]; 3],
            translation: [f64::MAX; 3],
        },
    );
    let w = wire(&worst);
    assert!(w.len() <= MAX_REQUEST, "{} bytes", w.len());
    let mut rx = Receiver::<MAX_REQUEST>::new();
    assert_eq!(feed(&mut rx, &w), vec![Ok(wire(&worst))]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Every request survives the trip, whatever garbage came before it
    /// (ended by a delimiter).
    #[test]
    fn requests_round_trip_after_garbage(
        seq in any::<u32>(),
        command in any_command(),
        garbage in proptest::collection::vec(any::<u8>(), 0..400),
    ) {
        let req = request(seq, command);
        let mut rx = Receiver::<MAX_REQUEST>::new();
        let mut bytes = garbage.clone();
        bytes.push(0);
        bytes.extend(wire(&req));
        let got = feed(&mut rx, &bytes);
        // f64 NaN != NaN: compare the encodings.
        let last = got.last().cloned().expect("the request's delimiter");
        let last = last.expect("the request decodes");
        prop_assert_eq!(last, wire(&req));
        prop_assert_eq!(rx.stats.bytes, bytes.len() as u64);
    }

    /// A corrupted request (bytes flipped) is never taken for another one:
    /// it either fails or decodes to exactly what was sent.
    #[test]
    fn corrupted_requests_are_refused(
        seq in any::<u32>(),
        command in any_command(),
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..4),
    ) {
        let req = request(seq, command);
        let mut bytes = wire(&req);
        let body = bytes.len() - 1;
        for (i, x) in flips {
            let i = i.index(body);
            bytes[i] ^= x;
        }
        let mut rx = Receiver::<MAX_REQUEST>::new();
        for got in feed(&mut rx, &bytes).into_iter().flatten() {
            prop_assert_eq!(got, wire(&req));
        }
    }

    /// Arbitrary bytes never panic, never produce more requests than
    /// delimiters, and the receiver stays usable.
    #[test]
    fn arbitrary_bytes_are_harmless(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let mut rx = Receiver::<MAX_REQUEST>::new();
        let got = feed(&mut rx, &bytes);
        prop_assert!(got.len() <= bytes.iter().filter(|b| **b == 0).count());
        let req = request(1, Command::Trigger { frames: 2 });
        let mut tail = vec![0u8];
        tail.extend(wire(&req));
        prop_assert_eq!(feed(&mut rx, &tail).last().cloned(), Some(Ok(wire(&req))));
    }
}

/// A message longer than the buffer is refused whole (not decoded from its
/// first N bytes), and the next one decodes.
#[test]
fn oversized_messages_are_refused_and_the_next_decodes() {
    let mut rx = Receiver::<MAX_REQUEST>::new();
    let mut bytes = vec![0x55u8; MAX_REQUEST + 1];
    bytes.push(0);
    let req = request(5, Command::Describe);
    bytes.extend(wire(&req));
    assert_eq!(
        feed(&mut rx, &bytes),
        vec![Err(RxError::Oversize), Ok(wire(&req))]
    );
    assert_eq!(rx.stats.errors, [1, 0, 0, 0]);
}

/// A body with a right CRC that is not the canonical encoding — a trailing
/// byte, an over-long varint — is refused (docs/wire.md).
#[test]
fn non_canonical_requests_are_refused() {
    let frame = |body: &[u8]| {
        let mut msg = body.to_vec();
        msg.extend_from_slice(&CRC32.checksum(body).to_le_bytes());
        let mut out = vec![0u8; msg.len() + msg.len() / 254 + 2];
        let k = cobs::encode(&msg, &mut out);
        out.truncate(k);
        out.push(0);
        out
    };
    let req = request(7, Command::Trigger { frames: 3 });
    let mut buf = [0u8; 16];
    let body = postcard::to_slice(&req, &mut buf).expect("encodes").to_vec();
    // version 2, seq 7, tag 4, frames 3.
    assert_eq!(body, vec![PROTOCOL_VERSION, 7, 4, 3]);
    let mut rx = Receiver::<MAX_REQUEST>::new();
    assert_eq!(feed(&mut rx, &frame(&body)), vec![Ok(wire(&req))]);
    let mut trailing = body.clone();
    trailing.push(0);
    assert_eq!(feed(&mut rx, &frame(&trailing)), vec![Err(RxError::Malformed)]);
    // seq 7 as the two-byte varint 87 00.
    let overlong = vec![PROTOCOL_VERSION, 0x87, 0x00, 4, 3];
    assert_eq!(feed(&mut rx, &frame(&overlong)), vec![Err(RxError::Malformed)]);
    // A wrong CRC.
    let mut bad = frame(&body);
    bad[2] ^= 1;
    assert_eq!(feed(&mut rx, &bad), vec![Err(RxError::Crc)]);
}

/// A camera library holding the standard scene (id 0).
fn lib() -> Library<'static, MAX_SCENE_DATA> {
    let blob: &'static [u8] = Box::leak(standard_bytes().into_boxed_slice());
    Library::new(Box::leak(Box::new([blob])), 640)
}

/// The sequence rule: the first number is free; then only the next one is
/// applied; a repeat of the last is answered again without being applied;
/// anything else is refused with the number expected. Describe is
/// answered whatever its number and does not count.
#[test]
fn commands_apply_once_and_in_order() {
    let mut scene = standard();
    let mut lib = lib();
    let mut c = Control::new();
    let trig = |seq| request(seq, Command::Trigger { frames: 2 });
    assert_eq!(c.handle(&trig(41), &mut scene, &mut lib), Answer::Ack);
    assert_eq!(c.pending, 2);
    // A repeat (the ack was lost): answered, not applied again.
    assert_eq!(c.handle(&trig(41), &mut scene, &mut lib), Answer::Ack);
    assert_eq!(c.pending, 2);
    // Skipping one, or going back: refused, nothing applied.
    for seq in [43, 40, 0, u32::MAX] {
        assert_eq!(
            c.handle(&trig(seq), &mut scene, &mut lib),
            Answer::Reject(Reason::OutOfOrder { expected: 42 }, Fault::field("seq"))
        );
    }
    assert_eq!(c.pending, 2);
    assert_eq!(
        c.handle(&request(9999, Command::Describe), &mut scene, &mut lib),
        Answer::Describe
    );
    assert_eq!(c.handle(&trig(42), &mut scene, &mut lib), Answer::Ack);
    assert_eq!((c.pending, c.last_command()), (4, Some(42)));
    // Another version: refused, not counted.
    let v1 = Request {
        version: 1,
        ..trig(43)
    };
    assert_eq!(
        c.handle(&v1, &mut scene, &mut lib),
        Answer::Reject(
            Reason::Version {
                speaks: PROTOCOL_VERSION
            },
            Fault::field("version")
        )
    );
    assert_eq!(c.last_command(), Some(42));
    // Numbers wrap.
    let mut c = Control::new();
    assert_eq!(c.handle(&trig(u32::MAX), &mut scene, &mut lib), Answer::Ack);
    assert_eq!(c.handle(&trig(0), &mut scene, &mut lib), Answer::Ack);
}

/// A repeat is recognised by its whole content: the last command's number
/// on another command is refused (`OutOfOrder`, naming `seq`) and not
/// applied; a true repeat's answer carries the first answer's time stamp,
/// so that its bytes are the same.
#[test]
fn a_repeat_is_the_same_command_and_gets_the_same_answer() {
    let mut scene = standard();
    let mut lib = lib();
    let mut c = Control::new();
    let k = scene.exposure();
    assert_eq!(
        c.handle(&request(7, Command::Trigger { frames: 1 }), &mut scene, &mut lib),
        Answer::Ack
    );
    assert_eq!(c.stamp(1_000), 1_000);
    // The trigger's number on an exposure: refused, the exposure unchanged.
    let expose = request(7, Command::SetExposure { k: 3.0 });
    assert_eq!(
        c.handle(&expose, &mut scene, &mut lib),
        Answer::Reject(Reason::OutOfOrder { expected: 8 }, Fault::field("seq"))
    );
    assert_eq!(scene.exposure(), k);
    assert_eq!(c.pending, 1);
    // The trigger again: the same answer with the first time stamp.
    assert_eq!(
        c.handle(&request(7, Command::Trigger { frames: 1 }), &mut scene, &mut lib),
        Answer::Ack
    );
    assert_eq!(c.stamp(5_000), 1_000);
    assert_eq!(c.pending, 1);
    // Another trigger count under the same number is another command.
    assert!(matches!(
        c.handle(&request(7, Command::Trigger { frames: 2 }), &mut scene, &mut lib),
        Answer::Reject(Reason::OutOfOrder { .. }, _)
    ));
    // The next command is stamped when it is answered.
    assert_eq!(c.handle(&expose_at(8), &mut scene, &mut lib), Answer::Ack);
    assert_eq!(c.stamp(9_000), 9_000);
    assert_ne!(scene.exposure(), k);
}

fn expose_at(seq: u32) -> Request<'static> {
    request(seq, Command::SetExposure { k: 3.0 })
}

/// A refused command names its field and changes nothing: the camera keeps
/// its last good pose, exposure, mode and scene.
#[test]
fn refused_commands_keep_the_last_good_state() {
    let mut scene = standard();
    let mut lib = lib();
    let good = scene.clone();
    let mut c = Control::new();
    let cases: Vec<(Command, Reason, &str)> = vec![
        (
            Command::SetPose {
                rotation: [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                translation: [0.0; 3],
            },
            Reason::Invalid,
            "pose.rotation",
        ),
        (
            Command::SetPose {
                rotation: [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                translation: [0.0; 3],
            },
            Reason::Invalid,
            "pose.rotation",
        ),
        (
            Command::SetPose {
                rotation: IDENTITY,
                translation: [0.0, f64::NAN, 0.0],
            },
            Reason::Invalid,
            "pose.translation",
        ),
        (
            Command::SetPose {
                rotation: IDENTITY,
                translation: [1000.5, 0.0, 0.0],
            },
            Reason::Invalid,
            "pose.translation",
        ),
        (Command::SetExposure { k: -1.0 }, Reason::Invalid, "exposure.k"),
        (
            Command::SetExposure { k: f64::NAN },
            Reason::Invalid,
            "exposure.k",
        ),
        (Command::SetExposure { k: 2e9 }, Reason::Invalid, "exposure.k"),
        (Command::Trigger { frames: 0 }, Reason::Invalid, "trigger.frames"),
        (Command::SelectScene { id: 1 }, Reason::Invalid, "scene.id"),
    ];
    for (seq, (cmd, reason, field)) in cases.into_iter().enumerate() {
        let a = c.handle(&request(seq as u32, cmd), &mut scene, &mut lib);
        assert_eq!(a, Answer::Reject(reason, Fault::field(field)), "{cmd:?}");
        assert_eq!(scene, good, "{cmd:?} changed the scene");
        assert_eq!((c.mode, c.pending, c.scene_id), (Mode::Triggered, 0, 0));
    }
    // Pending frames are bounded.
    let n = c.last_command().expect("counted") + 1;
    assert_eq!(
        c.handle(
            &request(n, Command::Trigger { frames: u16::MAX }),
            &mut scene,
            &mut lib
        ),
        Answer::Ack
    );
    assert_eq!(
        c.handle(
            &request(n + 1, Command::Trigger { frames: 1 }),
            &mut scene,
            &mut lib
        ),
        Answer::Reject(Reason::Invalid, Fault::field("trigger.frames"))
    );
    assert_eq!(c.pending, MAX_PENDING);
    // Trigger while free-running.
    assert_eq!(
        c.handle(
            &request(n + 2, Command::SetMode(Mode::FreeRun { period_us: 1000 })),
            &mut scene,
            &mut lib
        ),
        Answer::Ack
    );
    assert_eq!(
        c.handle(
            &request(n + 3, Command::Trigger { frames: 1 }),
            &mut scene,
            &mut lib
        ),
        Answer::Reject(Reason::WrongMode, Fault::field("mode"))
    );
    // A good pose and exposure are applied.
    let pose = Command::SetPose {
        rotation: IDENTITY,
        translation: [0.1, 0.2, -3.0],
    };
    assert_eq!(c.handle(&request(n + 4, pose), &mut scene, &mut lib), Answer::Ack);
    // Rounded to the position format (I24F40: half an LSB is 2⁻⁴¹ m).
    let t = scene.camera().extrinsics().translation().to_f64();
    for (got, want) in t.iter().zip([0.1, 0.2, -3.0]) {
        assert!((got - want).abs() <= 2f64.powi(-41), "{t:?}");
    }
    assert_eq!(
        c.handle(
            &request(n + 5, Command::SetExposure { k: 123.5 }),
            &mut scene,
            &mut lib
        ),
        Answer::Ack
    );
    assert_eq!(scene.exposure().to_num::<f64>(), 123.5);
}

/// The revision (what the camera plans again on) moves with every command
/// that changes the scene — a pose, an exposure, a scene selected, a scene
/// loaded whole — and with nothing else: not a trigger, a mode, a
/// description, a refused command, a repeat or a part of a scene.
#[test]
fn the_revision_moves_when_the_scene_changes() {
    let mut scene = standard();
    let mut lib = lib();
    let mut c = Control::new();
    let barrel = resolved("checkerboard-barrel.toml")
        .scene_bytes()
        .expect("scene data");
    let pose = |x: f64| Command::SetPose {
        rotation: IDENTITY,
        translation: [x, 0.2, -3.0],
    };
    let steps: Vec<(Command, bool)> = vec![
        (Command::Trigger { frames: 1 }, false),
        (pose(0.1), true),
        (Command::SetExposure { k: 123.5 }, true),
        (Command::SetExposure { k: -1.0 }, false),
        (Command::SelectScene { id: 1 }, false),
        (Command::SelectScene { id: 0 }, true),
        (Command::SetMode(Mode::FreeRun { period_us: 1000 }), false),
        (Command::SetMode(Mode::Triggered), false),
        (pose(f64::NAN), false),
        (pose(0.3), true),
    ];
    let mut seq = 0;
    for (cmd, changes) in steps {
        let (before, was) = (c.revision(), scene.clone());
        c.handle(&request(seq, cmd), &mut scene, &mut lib);
        assert_eq!(c.revision() != before, changes, "{cmd:?}");
        assert_eq!(scene != was, changes, "{cmd:?}: the scene");
        // A repeat is answered, not applied; Describe does not count.
        let again = c.revision();
        c.handle(&request(seq, cmd), &mut scene, &mut lib);
        c.handle(&request(9999, Command::Describe), &mut scene, &mut lib);
        assert_eq!(c.revision(), again, "{cmd:?} repeated");
        seq += 1;
    }
    // A scene in parts: only the last part, which shows it, moves it.
    let parts: Vec<&[u8]> = barrel.chunks(MAX_SCENE_CHUNK).collect();
    assert!(parts.len() > 1);
    for (i, part) in parts.iter().enumerate() {
        let (before, was) = (c.revision(), scene.clone());
        let cmd = Command::LoadScene {
            total: barrel.len() as u16,
            offset: (i * MAX_SCENE_CHUNK) as u16,
            bytes: part,
        };
        assert_eq!(
            c.handle(&request(seq + i as u32, cmd), &mut scene, &mut lib),
            Answer::Ack
        );
        let whole = i + 1 == parts.len();
        assert_eq!((c.revision() != before, scene != was), (whole, whole), "part {i}");
    }
}

/// Frames due: one per trigger in triggered mode; in free run one a period
/// (back to back when late).
#[test]
fn frames_are_due_as_the_mode_says() {
    let mut scene = standard();
    let mut lib = lib();
    let mut c = Control::new();
    assert!(!c.frame_due(0));
    c.handle(&request(0, Command::Trigger { frames: 2 }), &mut scene, &mut lib);
    assert!(c.frame_due(5) && c.frame_due(5) && !c.frame_due(5));
    c.handle(
        &request(1, Command::SetMode(Mode::FreeRun { period_us: 10 })),
        &mut scene,
        &mut lib,
    );
    assert!(c.frame_due(100));
    // 10 µs after the frame that began at 100 ns: not 1 ns before.
    assert!(!c.frame_due(100 + 10_000 - 1));
    assert!(c.frame_due(100 + 10_000));
    assert!(c.frame_due(1_000_000), "late: at once");
}

/// The answers' bytes: what the encoder sends equals the `Message` enum's
/// encoding (tags 3, 4, 5), and the host decoder reads them back.
#[test]
fn replies_are_messages_three_to_five() {
    let scene = standard();
    let c = Control::new();
    let ack = Ack {
        seq: 3,
        timestamp_ns: 1_000_000,
    };
    let reject = Reject {
        seq: 4,
        reason: Reason::Invalid,
        field: "pose.rotation",
    };
    let desc: Description = c.describe(&scene, &lib(), 0);
    let mut enc = Encoder::<host_sim::link::sim::Recorder, 64>::new(Default::default()).expect("encoder");
    enc.send_reply(&ack).expect("ack");
    enc.send_reply(&reject).expect("reject");
    enc.send_reply(&desc).expect("description");
    let sent = enc.into_inner().bytes;
    let mut want = Vec::new();
    for m in [
        Message::Ack(ack),
        Message::Reject(reject),
        Message::Description(desc),
    ] {
        let mut buf = [0u8; 256];
        want.extend_from_slice(encode_message(&m, &mut buf).expect("encodes"));
    }
    assert_eq!(sent, want);
    let mut dec = host_sim::link::decoder::Decoder::new(1 << 16, 1 << 20);
    dec.push(&sent, &mut |_| {});
    assert_eq!(dec.stats.replies, 3);
    assert_eq!(
        dec.replies.pop_front(),
        Some(host_sim::link::decoder::Reply::Ack(ack))
    );
}

/// MESSAGE_MAX bounds every message but a chunk: a FrameStart and the
/// answers with every varint at its longest.
#[test]
fn message_max_bounds_every_header_and_answer() {
    use hilcam::link::{FrameStart, Truth, WireFormat, WirePlan, MESSAGE_MAX};
    let start = FrameStart {
        version: u8::MAX,
        frame_id: u32::MAX,
        width: u16::MAX,
        height: u16::MAX,
        format: WireFormat::Gray16 { bits: u8::MAX },
        scene_id: u32::MAX,
        exposure: i64::MIN,
        truth: Truth {
            timestamp_ns: u64::MAX,
            command: Some(u32::MAX),
            rotation: [[i64::MIN; 3]; 3],
            translation: [i64::MIN; 3],
            focal_length: i64::MIN,
            pitch: [i64::MIN; 2],
            principal_point: [i32::MIN; 2],
            distortion: [i64::MIN; 2],
            lens: [i64::MIN; 2],
            model_scale: i64::MIN,
            plan: WirePlan {
                arithmetic: u8::MAX,
                model: u8::MAX,
                distortion: u8::MAX,
                table_entries: u16::MAX,
                samples: u8::MAX,
                adaptive: true,
                aperture: u16::MAX,
                noise: true,
            },
        },
    };
    let size = |m: &Message| {
        postcard::serialize_with_flavor::<_, postcard::ser_flavors::Size, usize>(m, Default::default())
            .expect("size")
    };
    assert_eq!(size(&Message::FrameStart(start)), MESSAGE_MAX);
    let longest_field = &"x".repeat(FIELD_MAX);
    for m in [
        Message::Reject(Reject {
            seq: u32::MAX,
            reason: Reason::OutOfOrder { expected: u32::MAX },
            field: longest_field,
        }),
        Message::Ack(Ack {
            seq: u32::MAX,
            timestamp_ns: u64::MAX,
        }),
        Message::Description(Description {
            version: u8::MAX,
            scenes: u32::MAX,
            scene_id: u32::MAX,
            width: u16::MAX,
            height: u16::MAX,
            format: WireFormat::Gray16 { bits: u8::MAX },
            mode: Mode::FreeRun { period_us: u32::MAX },
            pending: u32::MAX,
            last_command: Some(u32::MAX),
            next_frame: u32::MAX,
            max_request: u32::MAX,
            max_scene: u32::MAX,
            max_table: u32::MAX,
        }),
    ] {
        assert!(size(&m) <= MESSAGE_MAX, "{m:?}: {}", size(&m));
    }
}

/// Sends `bytes` as LoadScene parts of `chunk` bytes from sequence number
/// `seq`; returns every answer.
fn load_parts(
    c: &mut Control,
    scene: &mut Scene,
    lib: &mut Library<'_, MAX_SCENE_DATA>,
    seq: u32,
    bytes: &[u8],
    chunk: usize,
) -> Vec<Answer> {
    bytes
        .chunks(chunk)
        .enumerate()
        .map(|(i, part)| {
            let cmd = Command::LoadScene {
                total: bytes.len() as u16,
                offset: (i * chunk) as u16,
                bytes: part,
            };
            let req = request(seq + i as u32, cmd);
            // Every part fits the receiver.
            assert!(wire(&req).len() <= MAX_REQUEST);
            c.handle(&req, scene, lib)
        })
        .collect()
}

/// A scene sent as data in parts is built, checked and shown, as the host
/// builds it; it becomes the last scene id, and can be selected again.
#[test]
fn a_scene_loaded_in_parts_is_shown() {
    let mut scene = standard();
    let mut lib = lib();
    let mut c = Control::new();
    let barrel = resolved("checkerboard-barrel.toml");
    let bytes = barrel.scene_bytes().expect("scene data");
    let answers = load_parts(&mut c, &mut scene, &mut lib, 0, &bytes, MAX_SCENE_CHUNK);
    assert!(answers.len() > 1, "several parts");
    assert!(answers.iter().all(|a| *a == Answer::Ack), "{answers:?}");
    assert_eq!(scene, barrel.core_scene().expect("core scene"));
    assert_eq!((c.scene_id, lib.count()), (1, 2));
    assert_eq!(c.describe(&scene, &lib, 0).scenes, 2);
    let n = answers.len() as u32;
    assert_eq!(
        c.handle(&request(n, Command::SelectScene { id: 0 }), &mut scene, &mut lib),
        Answer::Ack
    );
    assert_eq!(scene, standard());
    assert_eq!(
        c.handle(
            &request(n + 1, Command::SelectScene { id: 1 }),
            &mut scene,
            &mut lib
        ),
        Answer::Ack
    );
    assert_eq!(scene, barrel.core_scene().expect("core scene"));
}

/// The loaded scene's id stays in the list while another scene's parts
/// arrive and after another is refused: the camera goes on showing it
/// under that id, refuses to select it again (`Unsupported`: its bytes are
/// gone) and selects the others; a scene loaded whole takes the id.
#[test]
fn scene_ids_stay_defined_through_an_unfinished_or_refused_load() {
    let mut scene = standard();
    let mut lib = lib();
    let mut c = Control::new();
    let barrel = resolved("checkerboard-barrel.toml");
    let bytes = barrel.scene_bytes().expect("scene data");
    let mut seq = load_parts(&mut c, &mut scene, &mut lib, 0, &bytes, MAX_SCENE_CHUNK).len() as u32;
    assert_eq!((c.scene_id, lib.count()), (1, 2));
    // Another scene's first part only, then a bad scene whole.
    let other = standard_bytes();
    let first = Command::LoadScene {
        total: other.len() as u16,
        offset: 0,
        bytes: &other[..MAX_SCENE_CHUNK],
    };
    let answers = [c.handle(&request(seq, first), &mut scene, &mut lib)];
    seq += 1;
    assert_eq!(answers, [Answer::Ack]);
    let d = c.describe(&scene, &lib, 0);
    assert!(d.scene_id < d.scenes, "{d:?}");
    assert_eq!(scene, barrel.core_scene().expect("core scene"));
    let select = |c: &mut Control, scene: &mut Scene, lib: &mut Library<'_, MAX_SCENE_DATA>, seq, id| {
        c.handle(&request(seq, Command::SelectScene { id }), scene, lib)
    };
    assert_eq!(
        select(&mut c, &mut scene, &mut lib, seq, 1),
        Answer::Reject(Reason::Unsupported, Fault::field("scene.id"))
    );
    assert_eq!(
        select(&mut c, &mut scene, &mut lib, seq + 1, 2),
        Answer::Reject(Reason::Invalid, Fault::field("scene.id"))
    );
    seq += 2;
    let mut bad = resolved("standard.toml").scene_data().expect("scene data");
    bad.materials[1].albedo = hilcam::scene::data::Colour::Gray(1.5);
    let mut buf = vec![0u8; MAX_SCENE_DATA];
    let bad = bad.encode(&mut buf).expect("fits").to_vec();
    let answers = load_parts(&mut c, &mut scene, &mut lib, seq, &bad, MAX_SCENE_CHUNK);
    seq += answers.len() as u32;
    assert!(matches!(answers.last(), Some(Answer::Reject(Reason::Invalid, _))));
    let d = c.describe(&scene, &lib, 0);
    assert_eq!((d.scene_id, d.scenes), (1, 2));
    assert_eq!(select(&mut c, &mut scene, &mut lib, seq, 0), Answer::Ack);
    assert_eq!(scene, standard());
    // A scene loaded whole takes the id again.
    let answers = load_parts(&mut c, &mut scene, &mut lib, seq + 1, &bytes, MAX_SCENE_CHUNK);
    assert!(answers.iter().all(|a| *a == Answer::Ack));
    assert_eq!((c.scene_id, lib.count()), (1, 2));
    assert_eq!(scene, barrel.core_scene().expect("core scene"));
}

/// The standard scene with [`hilcam::scene::MAX_PRIMITIVES`] + 1 copies of
/// its first primitive, encoded (SceneData holds at most the maximum: the
/// encoding of the maximum, its list length raised by one and one more
/// copy of the primitive inserted).
fn one_primitive_too_many() -> Vec<u8> {
    let mut data = resolved("standard.toml").scene_data().expect("scene data");
    let first = data.primitives[0];
    let encode = |data: &hilcam::scene::data::SceneData| {
        let mut buf = vec![0u8; MAX_SCENE_DATA];
        data.encode(&mut buf).expect("fits").to_vec()
    };
    let max = hilcam::scene::MAX_PRIMITIVES;
    data.primitives.clear();
    for _ in 0..max {
        data.primitives.push(first).expect("room");
    }
    let full = encode(&data);
    data.primitives.pop();
    let less = encode(&data);
    // The list's length is the first byte that differs (one byte below 128).
    let at = full.iter().zip(&less).position(|(a, b)| a != b).expect("differ");
    assert_eq!((full[at], less[at]), (max as u8, max as u8 - 1));
    let item = full[at + 1..at + 1 + full.len() - less.len()].to_vec();
    let mut more = full[..at].to_vec();
    more.push(max as u8 + 1);
    more.extend_from_slice(&item);
    more.extend_from_slice(&full[at + 1..]);
    more
}

/// A scene that fails is refused at its last part, naming the value; the
/// camera shows what it showed. Parts out of place are refused.
#[test]
fn a_bad_scene_is_refused_naming_the_field_and_the_camera_keeps_its_scene() {
    let good = standard();
    let mut data = resolved("standard.toml").scene_data().expect("scene data");
    data.materials[1].albedo = hilcam::scene::data::Colour::Gray(1.5);
    let mut buf = vec![0u8; MAX_SCENE_DATA];
    let bad = data.encode(&mut buf).expect("fits").to_vec();
    // A colour triple in a gray scene, as a scene file's is refused.
    let mut data = resolved("standard.toml").scene_data().expect("scene data");
    data.materials[0].albedo = hilcam::scene::data::Colour::Rgb([0.5, 0.2, 0.1]);
    let rgb_material = data.encode(&mut buf).expect("fits").to_vec();
    let mut data = resolved("standard.toml").scene_data().expect("scene data");
    data.background = hilcam::scene::data::Colour::Rgb([0.5, 0.2, 0.1]);
    let rgb_background = data.encode(&mut buf).expect("fits").to_vec();
    let cases: Vec<(Vec<u8>, u16, Reason, &str)> = vec![
        (bad, 640, Reason::Invalid, "materials[1].albedo"),
        (rgb_material, 640, Reason::Invalid, "materials[0].albedo"),
        (rgb_background, 640, Reason::Invalid, "environment.background"),
        // One primitive more than the camera's build holds.
        (one_primitive_too_many(), 640, Reason::Unsupported, "primitives"),
        // 160 pixels wide, the camera's lines 100.
        (standard_bytes(), 100, Reason::Unsupported, "camera.width"),
        (vec![0xff; 40], 640, Reason::Invalid, "scene"),
    ];
    for (bytes, width, reason, field) in cases {
        let blob: &'static [u8] = Box::leak(standard_bytes().into_boxed_slice());
        let mut lib = Library::<MAX_SCENE_DATA>::new(Box::leak(Box::new([blob])), width);
        let mut scene = good.clone();
        let mut c = Control::new();
        let answers = load_parts(&mut c, &mut scene, &mut lib, 0, &bytes, 64);
        let (last, before) = answers.split_last().expect("parts");
        assert!(before.iter().all(|a| *a == Answer::Ack));
        match last {
            Answer::Reject(r, f) => {
                assert_eq!((*r, f.name().as_str()), (reason, field));
            }
            other => panic!("{field}: {other:?}"),
        }
        assert_eq!(scene, good, "{field}: the scene changed");
        assert_eq!((c.scene_id, lib.count()), (0, 1));
    }
    // Parts out of place.
    let mut scene = good.clone();
    let mut lib = lib();
    let mut c = Control::new();
    let part = [0u8; 8];
    let load = |total, offset, bytes| Command::LoadScene { total, offset, bytes };
    let cases: Vec<(Command, &str)> = vec![
        (load(MAX_SCENE_DATA as u16 + 1, 0, &part[..]), "load.total"),
        (load(0, 0, &part[..]), "load.total"),
        (load(16, 8, &part[..]), "load.offset"),
        (load(4, 0, &part[..]), "load.bytes"),
        (load(16, 0, &[][..]), "load.bytes"),
    ];
    for (seq, (cmd, field)) in cases.into_iter().enumerate() {
        assert_eq!(
            c.handle(&request(seq as u32, cmd), &mut scene, &mut lib),
            Answer::Reject(Reason::Invalid, Fault::field(field)),
            "{cmd:?}"
        );
    }
    // A part skipped: the next is refused; starting again works.
    let bytes = standard_bytes();
    let n = 5;
    let first = load(bytes.len() as u16, 0, &bytes[..32]);
    assert_eq!(c.handle(&request(n, first), &mut scene, &mut lib), Answer::Ack);
    let third = load(bytes.len() as u16, 64, &bytes[64..96]);
    assert_eq!(
        c.handle(&request(n + 1, third), &mut scene, &mut lib),
        Answer::Reject(Reason::Invalid, Fault::field("load.offset"))
    );
    let answers = load_parts(&mut c, &mut scene, &mut lib, n + 2, &bytes, MAX_SCENE_CHUNK);
    assert!(answers.iter().all(|a| *a == Answer::Ack), "{answers:?}");
    assert_eq!((c.scene_id, lib.count()), (1, 2));
}

/// The longest LoadScene (every varint at its longest, a full part) fits
/// the receiver.
#[test]
fn the_largest_load_part_fits_the_receiver() {
    let part = [0xffu8; MAX_SCENE_CHUNK];
    let worst = request(
        u32::MAX,
        Command::LoadScene {
            total: u16::MAX,
            offset: u16::MAX,
            bytes: &part,
        },
    );
    let w = wire(&worst);
    assert!(w.len() <= MAX_REQUEST, "{} bytes", w.len());
    let mut rx = Receiver::<MAX_REQUEST>::new();
    assert_eq!(feed(&mut rx, &w), vec![Ok(w.clone())]);
}

/// A camera says the distortion table it plans within, so that a host
/// rendering its frames plans with the same budget (host-sim drive).
#[test]
fn a_camera_describes_the_table_it_plans_within() {
    let blob: &'static [u8] = Box::leak(standard_bytes().into_boxed_slice());
    let none = Library::<MAX_SCENE_DATA, 0>::new(Box::leak(Box::new([blob])), 640);
    let scene = none
        .scene(0)
        .expect("a camera without a table shows the standard scene");
    assert_eq!(Control::new().describe(&scene, &none, 0).max_table, 0);
    assert_eq!(
        Control::new().describe(&scene, &lib(), 0).max_table,
        hilcam::geom::distortion::MAX_LUT as u32
    );
}
