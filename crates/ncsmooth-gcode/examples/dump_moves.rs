//! Dev tool: prints, per G-code file, the number of moves and events and a digest of the
//! parsed geometry (end points rounded to 1e-9 mm), to compare interpreters.
//!
//! `cargo run --release -p ncsmooth-gcode --example dump_moves -- FILE...`

use ncsmooth::geom::ParamCurve;
use ncsmooth::path::Block;
use std::hash::{Hash, Hasher};

fn main() {
    let opts = if std::env::var_os("UNKNOWN").is_some() {
        ncsmooth_gcode::ParseOptions::default()
    } else {
        ncsmooth_gcode::ParseOptions::with_machine(ncsmooth_gcode::MachineModel::default())
    };
    for path in std::env::args().skip(1) {
        let bytes = std::fs::read(&path).expect("readable file");
        match ncsmooth_gcode::parse_bytes(&bytes, &path, &opts) {
            Err(e) => println!("{path}: error {e}"),
            Ok(p) => {
                let mut h = std::collections::hash_map::DefaultHasher::new();
                let (mut moves, mut events) = (0, 0);
                for b in &p.toolpath.blocks {
                    match b {
                        Block::Move(m) => {
                            moves += 1;
                            for q in [m.segment.start(), m.segment.eval(0.5), m.segment.end()] {
                                for v in [q.x, q.y, q.z] {
                                    ((v * 1e9).round() as i64).hash(&mut h);
                                }
                            }
                            m.is_rapid().hash(&mut h);
                            m.feed_mm_s.map(|f| (f * 1e9).round() as i64).hash(&mut h);
                        }
                        Block::Event(_) => events += 1,
                    }
                }
                println!(
                    "{path}: moves {moves} events {events} untracked {} {:?} digest {:016x}",
                    p.stats.untracked,
                    p.stats.untracked_first,
                    h.finish()
                );
            }
        }
    }
}
