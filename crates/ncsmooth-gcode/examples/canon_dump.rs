//! Dev tool: prints the canonical commands of a program on LinuxCNC's standalone machine
//! (zero offsets, inch parameters), to compare with `rs274 -g`.
//!
//! `cargo run -p ncsmooth-gcode --example canon_dump -- FILE`

fn main() {
    let path = std::env::args().nth(1).expect("a file");
    let src = std::fs::read(&path).expect("readable");
    let mut opts = ncsmooth_gcode::ParseOptions::with_machine(ncsmooth_gcode::MachineModel {
        machine_units: ncsmooth::Units::Inches,
        ..Default::default()
    });
    opts.canon = true;
    match ncsmooth_gcode::parse_bytes(&src, &path, &opts) {
        Ok(p) => p.canon.iter().for_each(|c| println!("{c:?}")),
        Err(e) => println!("error: {e}"),
    }
}
