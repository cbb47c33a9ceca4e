//! Generates the catalog's `bcc7` and `fcc6` modules (embedded layout, fast
//! variant) into OUT_DIR for the runtime to include, e.g.
//! `include_str!(concat!(env!("OUT_DIR"), "/bcc7.embedded.wgsl"))`.
fn main() {
    // Only catalog filters (no spec files to watch): without this line Cargo
    // would rerun the derivation after every edit anywhere in the package.
    println!("cargo:rerun-if-changed=build.rs");
    if let Err(e) = boxforge::Builder::new().filter("bcc7").filter("fcc6").generate() {
        panic!("boxforge: {e}");
    }
}
