//! Compiles the C-variadic FMI 2.0 logger callback (stable Rust cannot define one).

fn main() {
    println!("cargo:rerun-if-changed=src/logger.c");
    cc::Build::new().file("src/logger.c").warnings(true).compile("inchworm_fmi_import_logger");
}
