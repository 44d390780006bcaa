//! `cargo xtask` — luxbake's project commands.
fn main() {}
