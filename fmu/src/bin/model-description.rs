//! Prints `modelDescription.xml` (used by `cargo xtask fmu`, which packages the FMU); with
//! `--variables-md` the variables table of docs/fmu-variables.md; with `--check-plugin PATH`
//! checks that PATH is a strategy plugin the FMU can run (before xtask packs it).
//! `generationDateAndTime` is `SOURCE_DATE_EPOCH` when set (reproducible builds), else now.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        [] => fmu::xml::generation_time().map(fmu::xml::model_description),
        ["--variables-md"] => Ok(fmu::docs::variables_markdown()),
        ["--check-plugin", path] => {
            fmu::drive::check_plugin(std::path::Path::new(path)).map(|()| String::new())
        }
        _ => Err(format!(
            "unknown arguments `{}` (arguments: none, --variables-md, or --check-plugin PATH)",
            args.join(" ")
        )),
    };
    match out {
        Ok(text) => print!("{text}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
