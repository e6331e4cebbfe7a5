//! Every path a command writes, checked by one rule before any work is done: an error
//! names the option, the path and the rule, whichever option it is.

use std::path::{Path, PathBuf};

/// One output of a command: the option that named it and what it must be.
pub struct Output {
    /// The option, as typed (`--json`).
    pub option: &'static str,
    /// The path given.
    pub path: PathBuf,
    /// A folder (made if missing) rather than a file.
    pub folder: bool,
}

impl Output {
    /// A file written by `option`.
    pub fn file(option: &'static str, path: impl Into<PathBuf>) -> Self {
        Output {
            option,
            path: path.into(),
            folder: false,
        }
    }

    /// A folder written into by `option`.
    pub fn folder(option: &'static str, path: impl Into<PathBuf>) -> Self {
        Output {
            option,
            path: path.into(),
            folder: true,
        }
    }

    /// The file `name` in this folder, written by the same option.
    pub fn inside(&self, name: &str) -> Self {
        Output::file(self.option, self.path.join(name))
    }

    fn refused(&self, what: impl std::fmt::Display, rule: &str) -> String {
        format!(
            "{} {}: {what} (rule: {rule})",
            self.option,
            self.path.display()
        )
    }
}

/// Checks `outputs` in order: each file a writable path in a folder that exists, each
/// folder made if missing (so that its files can be checked), no path given twice.
/// Found out before the run, not after it.
pub fn check(outputs: &[Output]) -> Result<(), String> {
    for (k, o) in outputs.iter().enumerate() {
        if let Some(first) = outputs[..k].iter().find(|p| p.path == o.path) {
            let also = format!("also given to {}", first.option);
            return Err(o.refused(also, "each output its own path"));
        }
        if o.folder {
            check_folder(o)?;
        } else {
            check_file(o)?;
        }
    }
    Ok(())
}

fn check_folder(o: &Output) -> Result<(), String> {
    const RULE: &str = "a folder, made if missing";
    if o.path.exists() && !o.path.is_dir() {
        return Err(o.refused("is a file", RULE));
    }
    std::fs::create_dir_all(&o.path)
        .map_err(|e| o.refused(format!("cannot be made: {e}"), RULE))?;
    if readonly(&o.path) {
        return Err(o.refused("not writable", RULE));
    }
    Ok(())
}

fn check_file(o: &Output) -> Result<(), String> {
    if o.path.is_dir() {
        return Err(o.refused("is a folder", "a file path"));
    }
    let dir = match o.path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        let missing = format!("folder {} does not exist", dir.display());
        return Err(o.refused(missing, "create it first"));
    }
    if readonly(dir) || std::fs::metadata(&o.path).is_ok_and(|m| m.permissions().readonly()) {
        return Err(o.refused("not writable", "a path this user may write"));
    }
    Ok(())
}

fn readonly(p: &Path) -> bool {
    std::fs::metadata(p).is_ok_and(|m| m.permissions().readonly())
}
