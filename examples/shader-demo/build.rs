//! Generates `bcc7.embedded.wgsl` (catalog) and `my_qzp.embedded.wgsl`
//! (filters/my_filter.toml) into OUT_DIR; src/main.rs includes them.
fn main() {
    if let Err(e) = boxforge::Builder::new().filter("bcc7").spec_file("filters/my_filter.toml").generate() {
        panic!("boxforge: {e}");
    }
}
