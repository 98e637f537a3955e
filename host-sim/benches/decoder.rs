//! Decoder throughput: decodes a stream of 200 standard-scene frames
//! (160×120 Gray8, ~3.9 MB on the wire) 15 times and reports the median
//! rate in MB/s of wire bytes. A benchmark, not a test: run it with
//! `cargo bench -p host-sim --bench decoder`.

use host_sim::link::decoder::Decoder;
use host_sim::link::sim::send_frames;
use host_sim::stream_cmd::core_frame;
use std::path::Path;
use std::time::Instant;

fn main() {
    let standard = host_sim::scene_file::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/standard.toml"
    )))
    .expect("standard scene");
    let (pixels, start) = core_frame(&standard, 0).expect("renders");
    let sent = send_frames(&pixels, start, 200, None).expect("encodes");
    let mut rates = Vec::new();
    for _ in 0..15 {
        let mut dec = Decoder::new(1 << 20, 1 << 24);
        let mut frames = 0u64;
        let t = Instant::now();
        // feed in 4 KiB pieces, as a serial reader would
        for piece in sent.stream.chunks(4096) {
            dec.push(piece, &mut |_| frames += 1);
        }
        let secs = t.elapsed().as_secs_f64();
        assert_eq!(frames, 200);
        rates.push(sent.stream.len() as f64 / secs / 1e6);
    }
    rates.sort_by(f64::total_cmp);
    let median = rates[rates.len() / 2];
    println!(
        "decoder throughput: median {median:.0} MB/s of wire bytes (min {:.0}, max {:.0}) over 15 runs of {:.1} MB \
         (200 frames, 160x120 gray8); {:.0} frames/s",
        rates[0],
        rates[rates.len() - 1],
        sent.stream.len() as f64 / 1e6,
        median * 1e6 / (sent.stream.len() as f64 / 200.0)
    );
}
