//! Runs inputs through a harness on stable Rust and prints how long each
//! took, to reproduce a finding or time a corpus file:
//!
//! ```sh
//! cargo run --release -p motet-fuzz --example run -- svg fuzz/artifacts/svg/crash-…
//! ```
//!
//! A defect panics with the harness's message (and the exit status says so).

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(target) = args.next() else {
        eprintln!("usage: run TARGET FILE...");
        std::process::exit(2);
    };
    let Some(harness) = motet_fuzz::target(&target) else {
        let names: Vec<&str> = motet_fuzz::TARGETS.iter().map(|(n, _)| *n).collect();
        eprintln!("no target {target}; targets: {}", names.join(", "));
        std::process::exit(2);
    };
    for path in args {
        let data = match std::fs::read(&path) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{path}: {e}");
                std::process::exit(1);
            }
        };
        let t = std::time::Instant::now();
        harness(&data);
        println!(
            "{path}: {} bytes, {:.3} ms",
            data.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
    }
}
