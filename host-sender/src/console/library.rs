//! The console's program library and macros, kept by serve on disk so that they outlive a page
//! reload and a serve restart: `$XDG_DATA_HOME/gantry/console` (else
//! `~/.local/share/gantry/console`), mode 0700. Each program is `<name>` with its facts in
//! `<name>.json` (name, size, date, planned time, tools, lines, errors, as its check found them
//! when it was stored); the macros (named MDI snippets) are `macros.json`. Every file is
//! replaced in one step (written to a new file created exclusively, then renamed), never
//! through a link.

use anyhow::Context;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// The longest program name kept.
const NAME_MAX: usize = 100;
/// The most macros kept, and the longest macro text (bytes).
const MACROS_MAX: usize = 100;
const MACRO_TEXT_MAX: usize = 16 << 10;

/// The library's directory.
pub(crate) struct Library {
    dir: PathBuf,
}

/// The directory the console keeps its files in, by the XDG rules.
pub(crate) fn default_dir() -> Option<PathBuf> {
    let data = std::env::var_os("XDG_DATA_HOME")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .filter(|d| !d.is_empty())
                .map(|h| PathBuf::from(h).join(".local/share"))
        })?;
    Some(data.join("gantry").join("console"))
}

/// A program name as a file name: letters, digits, `.`, `-` and `_` (others become `_`), not
/// starting with a dot, at most [`NAME_MAX`] characters.
pub(crate) fn file_name(name: &str) -> Result<String, String> {
    let n: String = name
        .chars()
        .take(NAME_MAX)
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let n = n.trim_start_matches('.').to_owned();
    if n.is_empty() || n.ends_with(".json") || n == "macros" {
        return Err(format!("{name:?}: not a usable program name"));
    }
    Ok(n)
}

impl Library {
    /// Opens (creating it, private) the directory `dir`.
    pub(crate) fn open(dir: &Path) -> anyhow::Result<Library> {
        use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let meta = std::fs::symlink_metadata(dir)?;
        anyhow::ensure!(meta.is_dir(), "{}: not a directory", dir.display());
        if meta.permissions().mode() & 0o077 != 0 {
            std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700))
                .with_context(|| format!("cannot make {} private", dir.display()))?;
        }
        Ok(Library {
            dir: dir.to_owned(),
        })
    }

    pub(crate) fn dir(&self) -> &Path {
        &self.dir
    }

    /// Keeps `text` as program `name` with its check's facts (`summary`: lines, errors, seconds,
    /// tools); returns the entry.
    pub(crate) fn store(&self, name: &str, text: &str, summary: &Value) -> Result<Value, String> {
        let file = file_name(name)?;
        let entry = json!({
            "name": file, "size": text.len(), "date": now_s(),
            "lines": summary["lines"], "errors": summary["errors"],
            "seconds": summary["seconds"], "tools": summary["tools"],
        });
        replace(&self.dir.join(&file), text.as_bytes()).map_err(|e| format!("{e:#}"))?;
        replace(
            &self.dir.join(format!("{file}.json")),
            entry.to_string().as_bytes(),
        )
        .map_err(|e| format!("{e:#}"))?;
        Ok(entry)
    }

    /// The programs kept, newest first.
    pub(crate) fn list(&self) -> Vec<Value> {
        let mut out: Vec<Value> = std::fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let n = e.file_name().to_string_lossy().into_owned();
                let program = n.strip_suffix(".json")?;
                if program == "macros" || !self.dir.join(program).is_file() {
                    return None;
                }
                serde_json::from_slice::<Value>(&std::fs::read(e.path()).ok()?).ok()
            })
            .collect();
        out.sort_by(|a, b| {
            b["date"]
                .as_f64()
                .partial_cmp(&a["date"].as_f64())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        out
    }

    /// The text of program `name`.
    pub(crate) fn read(&self, name: &str) -> Result<String, String> {
        let file = file_name(name)?;
        std::fs::read_to_string(self.dir.join(&file))
            .map_err(|e| format!("{file}: not in the library ({e})"))
    }

    /// Removes program `name`.
    pub(crate) fn remove(&self, name: &str) -> Result<(), String> {
        let file = file_name(name)?;
        std::fs::remove_file(self.dir.join(&file))
            .map_err(|e| format!("{file}: not in the library ({e})"))?;
        let _ = std::fs::remove_file(self.dir.join(format!("{file}.json")));
        Ok(())
    }

    /// The macros, in the order they were made.
    pub(crate) fn macros(&self) -> Vec<Value> {
        std::fs::read(self.dir.join("macros.json"))
            .ok()
            .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
            .and_then(|v| v.as_array().cloned())
            .unwrap_or_default()
    }

    /// Keeps macro `name` (replacing one of that name) with `text`, or removes it (`None`).
    pub(crate) fn set_macro(&self, name: &str, text: Option<&str>) -> Result<(), String> {
        let name = name.trim();
        if name.is_empty() || name.len() > NAME_MAX || name.chars().any(char::is_control) {
            return Err(format!("macro name {name:?}: 1 to {NAME_MAX} characters"));
        }
        let mut all = self.macros();
        let was = all.len();
        all.retain(|m| m["name"] != name);
        match text {
            Some(t) => {
                if t.trim().is_empty() || t.len() > MACRO_TEXT_MAX {
                    return Err(format!(
                        "macro {name}: its blocks, 1 to {MACRO_TEXT_MAX} bytes"
                    ));
                }
                if all.len() >= MACROS_MAX {
                    return Err(format!("at most {MACROS_MAX} macros"));
                }
                all.push(json!({ "name": name, "text": t }));
            }
            None if all.len() == was => return Err(format!("no macro {name}")),
            None => {}
        }
        replace(
            &self.dir.join("macros.json"),
            Value::from(all).to_string().as_bytes(),
        )
        .map_err(|e| format!("{e:#}"))
    }

    /// The text of macro `name`.
    pub(crate) fn macro_text(&self, name: &str) -> Result<String, String> {
        self.macros()
            .iter()
            .find(|m| m["name"] == name)
            .and_then(|m| m["text"].as_str().map(str::to_owned))
            .ok_or_else(|| format!("no macro {name}"))
    }
}

fn now_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Replaces `file` with `bytes` in one step (a new file of this process's, created exclusively,
/// mode 0600, then renamed over it).
fn replace(file: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    static COUNT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let tmp = file.with_file_name(format!(".{}.{n}.tmp", std::process::id()));
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(&tmp)
        .with_context(|| format!("cannot create {}", tmp.display()))?;
    let done = f.write_all(bytes).and_then(|()| f.sync_all());
    drop(f);
    if let Err(e) = done.and_then(|()| std::fs::rename(&tmp, file)) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("cannot write {}", file.display()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_file_names_in_the_library_only() {
        assert_eq!(file_name("pocket v2.nc").unwrap(), "pocket_v2.nc");
        assert_eq!(file_name("../../etc/passwd").unwrap(), "_.._etc_passwd");
        assert!(file_name("...").is_err());
        assert!(file_name("macros").is_err());
        assert!(file_name("a.json").is_err());
    }

    #[test]
    fn programs_and_macros_are_kept() {
        let dir = std::env::temp_dir().join(format!("gantry-library-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let lib = Library::open(&dir).unwrap();
        let s = json!({"lines": 3, "errors": 0, "seconds": 1.5, "tools": [2]});
        lib.store("a.nc", "G0 X1\n", &s).unwrap();
        let list = lib.list();
        assert_eq!(list.len(), 1);
        assert_eq!(list[0]["name"], "a.nc");
        assert_eq!(list[0]["size"], 6);
        assert_eq!(list[0]["tools"], json!([2]));
        assert_eq!(lib.read("a.nc").unwrap(), "G0 X1\n");
        lib.set_macro("park", Some("G53 G0 Z0")).unwrap();
        lib.set_macro("park", Some("G53 G0 Z-1")).unwrap();
        assert_eq!(lib.macro_text("park").unwrap(), "G53 G0 Z-1");
        assert_eq!(lib.macros().len(), 1);
        lib.set_macro("park", None).unwrap();
        assert!(lib.macro_text("park").is_err());
        lib.remove("a.nc").unwrap();
        assert!(lib.list().is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
