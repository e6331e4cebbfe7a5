//! Prints `modelDescription.xml` (used by `cargo xtask fmu`, which packages the FMU).

fn main() {
    print!("{}", fmu::xml::model_description());
}
