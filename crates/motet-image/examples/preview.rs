//! Draws what `motet-image` would plot, as a PNG, and prints statistics.
//!
//! `cargo run --release -p motet-image --example preview -- photo.jpg out.png [max_px] [blur] [high]`

use image::{Rgb, RgbImage};
use motet_image::{parse_with_info, ImageOptions};
use motet_planner::{AxisInfo, Command, JobTarget, ToolInfo, ToolKind};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (input, output) = (&args[1], &args[2]);
    let mut opts = ImageOptions::default();
    if let Some(v) = args.get(3) {
        opts.max_px = v.parse().unwrap();
    }
    if let Some(v) = args.get(4) {
        opts.blur_sigma = v.parse().unwrap();
    }
    if let Some(v) = args.get(5) {
        opts.high_threshold = v.parse().unwrap();
    }
    let axis = |name: &str| AxisInfo {
        name: name.into(),
        travel: [0.0, 200.0],
        path: true,
    };
    let target = JobTarget {
        axes: vec![axis("x"), axis("y")],
        tools: vec![ToolInfo {
            name: "pen".into(),
            kind: ToolKind::Pen,
            on_value: 1.0,
        }],
        start: [0.0; 6],
        tolerance: 0.01,
        draw_feed: 50.0,
    };
    let data = std::fs::read(input).unwrap();
    let t = std::time::Instant::now();
    let (cmds, info) = parse_with_info(&data, &target, &opts).unwrap();
    println!("{:?} in {:?}", info, t.elapsed());
    let px = 4.0; // preview pixels per mm
    let size = (200.0 * px) as u32;
    let mut img = RgbImage::from_pixel(size, size, Rgb([255, 255, 255]));
    let mut pos = [0.0f32; 2];
    let mut down = false;
    for c in &cmds {
        match c.item {
            Command::Tool { value, .. } => down = value > 0.0,
            Command::Move(m) => {
                let p = [m.target[0] as f32 * px, (200.0 - m.target[1] as f32) * px];
                if down {
                    imageproc::drawing::draw_line_segment_mut(
                        &mut img,
                        (pos[0], pos[1]),
                        (p[0], p[1]),
                        Rgb([0, 0, 0]),
                    );
                }
                pos = p;
            }
            _ => {}
        }
    }
    img.save(output).unwrap();
}
