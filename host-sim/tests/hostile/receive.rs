//! `receive`: missing, damaged, repeated and oversized frames, bad Gray16 depths, endless noise, Ctrl-C.

use super::*;

/// Fewer frames than asked for: the exit status says so, and the frames
/// that did arrive are on disk (written as they came), with receive.json.
#[test]
fn receive_fails_when_frames_are_missing_and_keeps_those_that_came() {
    let start = header(WireFormat::Gray8);
    let sent = send_frames(&[9u8; 64], start, 2, None).expect("encodes");
    let (r, out) = receive(
        "receive-missing",
        sent.stream,
        &["--frames", "3", "--timeout", "1"],
        None,
    );
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    assert!(r.stderr.contains("2 of 3 frames"), "{}", r.stderr);
    assert_eq!(
        entries(&out),
        ["frame-00000.png", "frame-00001.png", "receive.json"]
    );
    let json = std::fs::read_to_string(out.join("receive.json")).expect("receive.json");
    // The pty reports the hang-up as silence or as EIO, by timing.
    assert!(
        json.contains("\"received\": 2") && (json.contains("hangup") || json.contains("idle_timeout")),
        "{json}"
    );
}

/// A corrupted frame among intact ones (a flipped bit, a truncated chunk,
/// garbage between frames): every intact frame is written, no corrupted
/// one, and the status says one is missing.
#[test]
fn receive_keeps_every_intact_frame_of_a_damaged_stream() {
    let start = header(WireFormat::Gray8);
    let base: Vec<u8> = (0..64).map(|i| i as u8).collect();
    let sent = send_frames(&base, start, 6, None).expect("encodes");
    let mut stream = Vec::new();
    for (id, (a, b), _) in &sent.frames {
        let mut f = sent.stream[*a..*b].to_vec();
        match id {
            1 => f[20] ^= 0x10,                          // a flipped bit
            3 => f.truncate(f.len() - 9),                // the end cut short
            4 => stream.extend_from_slice(&[0x55; 300]), // garbage before it
            _ => {}
        }
        stream.extend_from_slice(&f);
    }
    let (r, out) = receive(
        "receive-damaged",
        stream,
        &["--frames", "6", "--timeout", "1"],
        None,
    );
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    // Frames 1 (bad CRC) and 3 (no end) are dropped; the garbage and
    // frame 3's tail end at frame 4's opening delimiter, and decoding
    // resumes there.
    assert!(r.stderr.contains("4 of 6 frames"), "{}", r.stderr);
    assert_eq!(
        entries(&out),
        [
            "frame-00000.png",
            "frame-00002.png",
            "frame-00004.png",
            "frame-00005.png",
            "receive.json"
        ]
    );
}

/// Frames that share an id (a sender that restarted) each get a file.
#[test]
fn repeated_frame_ids_do_not_overwrite_each_other() {
    let start = header(WireFormat::Gray8);
    let mut stream = Vec::new();
    for k in 0..3u8 {
        stream.extend(send_frames(&[k; 64], start, 1, None).expect("encodes").stream);
    }
    let (r, out) = receive("receive-repeated-ids", stream, &["--frames", "3"], None);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_eq!(
        entries(&out),
        [
            "frame-00000-2.png",
            "frame-00000-3.png",
            "frame-00000.png",
            "receive.json"
        ]
    );
}

/// A Gray16 frame with `bits` outside 9–16 is refused by the decoder, not
/// written as garbage (or a panic in the PNG writer's shift).
#[test]
fn gray16_bits_outside_9_to_16_are_refused() {
    for bits in [0u8, 8, 17, 255] {
        let start = header(WireFormat::Gray16 { bits });
        let mut enc = Encoder::<Recorder, 64>::new(Recorder::default()).expect("encoder");
        enc.begin_frame(start).expect("begin");
        for _ in 0..4 {
            enc.push_line(&[0xff; 32]).expect("line");
        }
        enc.end_frame(None).expect("end");
        let bytes = enc.into_inner().bytes;
        let mut dec = host_sim::link::decoder::Decoder::new(1 << 20, 1 << 24);
        let mut n = 0;
        dec.push(&bytes, &mut |_| n += 1);
        assert_eq!((n, dec.stats.frames_refused), (0, 1), "bits {bits}");
        if bits == 17 {
            let (r, out) = receive(
                "receive-gray16-17",
                bytes,
                &["--frames", "1", "--timeout", "1"],
                None,
            );
            assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
            assert!(r.stderr.contains("0 of 1 frames"), "{}", r.stderr);
            assert_eq!(entries(&out), ["receive.json"]);
        }
    }
}

/// Headers that claim huge frames (up to 16384×16384 RGB565, 512 MiB) are
/// refused at their start: the decoder never reserves more than its 16 MiB
/// frame limit, whatever a hostile link claims.
#[test]
fn frame_headers_claiming_huge_frames_are_refused() {
    // Only the header, as the wire carries it (a hostile sender need not
    // send the pixels, nor have an encoder that holds such lines):
    // COBS(postcard ‖ CRC-32 LE) 0x00.
    let wire = |start: FrameStart| {
        let mut body = [0u8; hilcam::link::MESSAGE_MAX];
        let n = postcard::to_slice(&hilcam::link::Message::FrameStart(start), &mut body)
            .expect("serializes")
            .len();
        let mut msg = body[..n].to_vec();
        msg.extend_from_slice(&hilcam::link::CRC32.checksum(&body[..n]).to_le_bytes());
        let mut bytes = vec![0u8; msg.len() + msg.len() / 254 + 2];
        let k = cobs::encode(&msg, &mut bytes);
        bytes.truncate(k);
        bytes.push(0);
        let mut dec = host_sim::link::decoder::Decoder::new(1 << 20, 1 << 24);
        dec.push(&bytes, &mut |_| {});
        dec.stats
    };
    // The encoding is right: a header within the limit is accepted.
    let ok = wire(FrameStart {
        width: 4096,
        height: 4096,
        ..header(WireFormat::Gray8)
    });
    assert_eq!((ok.messages_ok, ok.frames_refused), (1, 0));
    for (w, h, format) in [
        (16384u16, 16384u16, WireFormat::Rgb565),
        (16384, 1025, WireFormat::Gray8),
        (4097, 4096, WireFormat::Gray8),
    ] {
        let stats = wire(FrameStart {
            width: w,
            height: h,
            ..header(format)
        });
        assert_eq!(
            (stats.messages_ok, stats.frames_refused),
            (1, 1),
            "{w}x{h} {format:?}"
        );
    }
}

/// Garbage at the wrong baud rate, without end: the overall deadline stops
/// `receive`, with a failing status and receive.json.
#[test]
fn receive_stops_at_the_deadline_on_endless_noise() {
    let (child, mut master, slave, dir) = start_receive(
        "receive-noise",
        &["--frames", "1", "--timeout", "1", "--deadline", "2"],
    );
    let out = dir.join("out");
    let t = Instant::now();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let s2 = stop.clone();
    let noise = std::thread::spawn(move || {
        let mut x = 0x9e37_79b9_u32;
        while !s2.load(std::sync::atomic::Ordering::SeqCst) {
            let buf: Vec<u8> = (0..256)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x as u8 | 1 // never a delimiter: one endless message
                })
                .collect();
            let _ = master.write_all(&buf);
            std::thread::sleep(Duration::from_millis(5));
        }
    });
    let r = finish(child, &dir);
    let took = t.elapsed();
    stop.store(true, std::sync::atomic::Ordering::SeqCst);
    noise.join().expect("noise");
    drop(slave);
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    assert!(r.stderr.contains("deadline"), "{}", r.stderr);
    assert!(took < Duration::from_secs(30), "took {took:?}");
    assert_eq!(entries(&out), ["receive.json"]);
}

/// Ctrl-C (SIGINT) while receiving: the frames already received stay, and
/// receive.json says it was interrupted.
#[test]
fn receive_interrupted_keeps_the_frames_already_received() {
    let (child, mut master, slave, dir) =
        start_receive("receive-sigint", &["--frames", "5", "--timeout", "60"]);
    let out = dir.join("out");
    let sent = send_frames(&[5u8; 64], header(WireFormat::Gray8), 2, None).expect("encodes");
    master.write_all(&sent.stream).expect("write");
    let t = Instant::now();
    while entries(&out).iter().filter(|e| e.ends_with(".png")).count() < 2
        && t.elapsed() < Duration::from_secs(20)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let r = finish(child, &dir);
    drop(master);
    drop(slave);
    assert!(r.failed_cleanly(), "exit {:?}: {}", r.code, r.stderr);
    assert!(
        r.stderr.contains("2 of 5 frames") && r.stderr.contains("interrupted"),
        "{}",
        r.stderr
    );
    assert_eq!(
        entries(&out),
        ["frame-00000.png", "frame-00001.png", "receive.json"]
    );
}
