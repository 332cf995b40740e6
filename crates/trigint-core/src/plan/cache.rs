//! The plan cache: one file per CPU model and core version in the user's cache directory, its
//! first line naming the format, the core's version and build and the CPU; then a line per loop
//! (`copy<TAB>loop<TAB>timings`).

use std::collections::HashMap;
use std::path::PathBuf;

use super::{note, Isa, Planner};

/// The plan cache's file, if the user has a cache directory: `TRIGINT_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/trigint`, else `~/.cache/trigint` (`%LOCALAPPDATA%\trigint` on Windows).
pub fn cache_path() -> Option<PathBuf> {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    let dir = env("TRIGINT_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("trigint")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("trigint")))
        .or_else(|| env("LOCALAPPDATA").map(|d| d.join("trigint")))?;
    let model = crate::cpu::model();
    let slug: String = model
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .take(40)
        .collect();
    let file = format!(
        "plans-{}-{}-{:08x}.tsv",
        env!("CARGO_PKG_VERSION"),
        slug,
        crate::cpu::fingerprint() as u32
    );
    Some(dir.join(file))
}

/// The cache's first line: the format, the core's version and build (a hash of its sources,
/// from `build.rs`) and the CPU.
fn header() -> String {
    format!(
        "{HEADER_START} 2; core {}; build {}; cpu {}",
        env!("CARGO_PKG_VERSION"),
        build_id(),
        crate::cpu::model()
    )
}

const HEADER_START: &str = "# trigint kernel plans, format";

/// The kernels' build identity (see `build.rs`).
pub fn build_id() -> &'static str {
    env!("TRIGINT_KERNEL_BUILD")
}

/// The plans in the cache, or none with a note if it is damaged (a missing file is no news).
pub(super) fn read_cache(path: &PathBuf) -> HashMap<String, (Isa, String)> {
    let Ok(text) = std::fs::read(path) else {
        return HashMap::new();
    };
    let parsed = String::from_utf8(text)
        .map_err(|_| "not text".to_string())
        .and_then(|text| parse_cache(&text));
    match parsed {
        Ok(known) => known,
        Err(why) => {
            note(&format!(
                "ignored the kernel plan cache {} ({why}); plans are measured again",
                path.display()
            ));
            HashMap::new()
        }
    }
}

/// The plans of a cache file; none, without a note, from a cache of other kernels (another
/// version or build of the core, or an older format): its timings are not of these kernels'
/// loops, so they are measured again and the file rewritten.
fn parse_cache(text: &str) -> Result<HashMap<String, (Isa, String)>, String> {
    let mut lines = text.lines();
    match lines.next() {
        Some(first) if first == header() => {}
        Some(first) if first.starts_with(HEADER_START) => return Ok(HashMap::new()),
        _ => return Err("its first line is not a kernel plan header".into()),
    }
    let mut known = HashMap::new();
    for (i, line) in lines.enumerate() {
        let mut fields = line.split('\t');
        let (Some(isa), Some(key), Some(timings), None) =
            (fields.next(), fields.next(), fields.next(), fields.next())
        else {
            return Err(format!("line {} is not 'copy<TAB>loop<TAB>timings'", i + 2));
        };
        let isa = Isa::parse(isa).ok_or_else(|| format!("line {}: no copy {isa:?}", i + 2))?;
        known.insert(key.to_string(), (isa, timings.to_string()));
    }
    Ok(known)
}

impl Planner {
    /// Writes every known plan (a new file moved into place, so a reader never sees half of it).
    pub(super) fn write_cache(&mut self) {
        let Some(path) = self.cache.clone() else {
            return;
        };
        if self.write_failed {
            return;
        }
        let mut rows: Vec<_> = self.known.iter().collect();
        rows.sort_by(|a, b| a.0.cmp(b.0));
        let mut text = header();
        text.push('\n');
        for (key, (isa, timings)) in rows {
            text.push_str(&format!("{}\t{key}\t{timings}\n", isa.name()));
        }
        let tmp = path.with_extension(format!("tmp{}", std::process::id()));
        let written = path
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .and_then(|()| std::fs::write(&tmp, text))
            .and_then(|()| std::fs::rename(&tmp, &path));
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            self.write_failed = true;
            note(&format!(
                "could not write the kernel plan cache {} ({e}); plans are kept for this process only",
                path.display()
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cache_round_trips_and_a_damaged_one_is_refused() {
        let text = format!(
            "{}\navx2\tLoop<f64> n<=2^3\tbaseline=1 avx2=0.5\n",
            header()
        );
        let known = parse_cache(&text).unwrap();
        assert_eq!(known["Loop<f64> n<=2^3"].0, Isa::Avx2);
        assert!(parse_cache("garbage").is_err());
        // Plans of other kernels (another build, an older format) are dropped without a note.
        let other = text.replace(build_id(), "0123456789abcdef");
        assert!(parse_cache(&other).unwrap().is_empty());
        let older = "# trigint kernel plans, format 1; core 0.1.0; cpu X\navx2\tLoop\tavx2=1\n";
        assert!(parse_cache(older).unwrap().is_empty());
        let bad = format!("{}\nsse9\tLoop\tx\n", header());
        assert!(parse_cache(&bad).unwrap_err().contains("sse9"));
    }
}
