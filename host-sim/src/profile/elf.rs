//! A firmware ELF read: where its flash goes ([`FlashUse`]), its symbols'
//! names, and where its frames (or a function's calls) start and end
//! ([`Marks`]).

use super::Symbols;
use serde::Serialize;
use std::collections::HashMap;
use std::path::Path;

/// Bytes of flash one name holds.
#[derive(Clone, Debug, Serialize)]
pub struct Share {
    pub name: String,
    pub bytes: u64,
}

/// Where an ELF's flash goes: its largest symbols (code and data, names
/// without hashes; a generic function built for several types appears
/// once each) and `.text` by source file (the ELF's line tables and
/// inlined frames: the innermost of the repository's files, so a library
/// helper inlined into the renderer counts for the renderer's file; else
/// the library's, the standard library as `library/<crate>`, the
/// registry's as `<crate>-<version>`; code without line information as
/// `(none)`), largest first.
#[derive(Clone, Debug, Serialize)]
pub struct FlashUse {
    pub largest_symbols: Vec<Share>,
    pub text_by_file: Vec<Share>,
}

/// [`FlashUse`] of `elf`, its `top` largest symbols.
pub fn flash_use(elf: &Path, top: usize) -> Result<FlashUse, String> {
    use object::{Object, ObjectSection, ObjectSymbol, SymbolKind};
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", elf.display());
    let data = std::fs::read(elf).map_err(|e| err(&e))?;
    let file = object::File::parse(&*data).map_err(|e| err(&e))?;
    let mut largest: Vec<Share> = file
        .symbols()
        .filter(|s| s.size() > 0 && matches!(s.kind(), SymbolKind::Text | SymbolKind::Data))
        .map(|s| Share {
            name: name_of(s.name().unwrap_or("?")),
            bytes: s.size(),
        })
        .collect();
    largest.sort_by(|a, b| b.bytes.cmp(&a.bytes).then(a.name.cmp(&b.name)));
    largest.truncate(top);
    let text = file.section_by_name(".text").ok_or_else(|| err(&"no .text"))?;
    let symbols = Symbols::new(elf)?;
    let mut by_file: HashMap<String, u64> = HashMap::new();
    let mut covered = 0;
    let (lo, hi) = (text.address(), text.address() + text.size());
    for (addr, len, loc) in symbols.loader.find_location_range(lo, hi).map_err(|e| err(&e))? {
        let len = len.min(hi.saturating_sub(addr));
        covered += len;
        *by_file.entry(symbols.file_of(addr, loc.file)).or_default() += len;
    }
    if let Some(rest) = text.size().checked_sub(covered).filter(|r| *r > 0) {
        *by_file.entry("(none)".into()).or_default() += rest;
    }
    let mut text_by_file: Vec<Share> = by_file.into_iter().map(|(name, bytes)| Share { name, bytes }).collect();
    text_by_file.sort_by(|a, b| b.bytes.cmp(&a.bytes).then(a.name.cmp(&b.name)));
    Ok(FlashUse {
        largest_symbols: largest,
        text_by_file,
    })
}

/// The standard library's or a registry crate's.
pub(super) fn is_library(file: &str) -> bool {
    file.starts_with("/rustc/") || file.contains("/rustlib/") || file.contains("/registry/src/")
}

/// A source file as [`FlashUse`] names it.
pub(super) fn source_of(file: &str, root: &Path) -> String {
    if let Some((_, rest)) = file.split_once("/library/").filter(|_| file.starts_with("/rustc/") || file.contains("/rustlib/")) {
        return format!("library/{}", rest.split('/').next().unwrap_or("?"));
    }
    if let Some((_, rest)) = file.split_once("/registry/src/") {
        // index.crates.io-HASH/CRATE-VERSION/...
        return rest.split('/').nth(1).unwrap_or("?").to_string();
    }
    let path = Path::new(file);
    path.strip_prefix(root).unwrap_or(path).display().to_string()
}

/// A symbol's path, demangled without its hash (`rustc_demangle`'s
/// alternate form; a name that is not mangled stays as it is), an inherent
/// impl's method by its type's path (`a::b::<impl T>::f` as `T::f`), so
/// that a method is named the same whichever module its `impl` block is in.
pub(super) fn name_of(raw: &str) -> String {
    let mut name = format!("{:#}", rustc_demangle::demangle(raw));
    while let Some(at) = name.find("::<impl ") {
        let open = at + "::<impl ".len();
        // The `>` that closes `<impl`, past the type's own generics.
        let mut depth = 1usize;
        let close = name[open..].char_indices().find_map(|(i, c)| {
            match c {
                '<' => depth += 1,
                '>' => depth -= 1,
                _ => {}
            }
            (depth == 0).then_some(open + i)
        });
        let Some(close) = close else { break };
        let ty = &name[open..close];
        // A trait's impl (`<impl Trait for T>`) keeps its path.
        if ty.contains(" for ") {
            break;
        }
        let start = name[..at].rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).map_or(0, |i| i + 1);
        name = format!("{}{ty}{}", &name[..start], &name[close + 1..]);
    }
    name
}

/// Where the firmware's frames start and end: the entries of its
/// `<Run as Runner>::run` instances (one a number type), and the address
/// ranges of the loops that call them (`sweep`, the camera's `run`), to
/// which each frame returns.
pub fn frame_marks(elf: &Path) -> Result<Marks, String> {
    let m = marks_by(
        elf,
        |name| name.contains("as hilcam_firmware::Runner>::run"),
        |name| name == "hilcam_firmware::sweep" || name == "hilcam_firmware::camera::run",
    )?;
    if m.starts.is_empty() || m.callers.is_empty() {
        return Err(format!(
            "{}: no Runner::run or no sweep: not hilcam's firmware",
            elf.display()
        ));
    }
    Ok(m)
}

/// Where the calls of `function` start and end in `elf` (names as
/// [`name_of`] gives them, without hashes): its entries, and the address
/// ranges of `callers`, to which each call returns.
pub fn call_marks(elf: &Path, function: &str, callers: &[String]) -> Result<Marks, String> {
    let m = marks_by(elf, |name| name == function, |name| callers.iter().any(|c| c == name))?;
    if m.starts.is_empty() {
        return Err(format!("{}: no function {function}", elf.display()));
    }
    if m.callers.is_empty() {
        return Err(format!("{}: none of {callers:?} is a function here", elf.display()));
    }
    Ok(m)
}

/// The entries of the symbols `start` names, and the address ranges of
/// those `caller` names.
pub(super) fn marks_by(elf: &Path, start: impl Fn(&str) -> bool, caller: impl Fn(&str) -> bool) -> Result<Marks, String> {
    use object::{Object, ObjectSymbol};
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
    let mut m = Marks::default();
    for s in file.symbols() {
        let Ok(name) = s.name() else { continue };
        let name = name_of(name);
        let addr = (s.address() as u32) & !1;
        if start(&name) {
            m.starts.push(addr);
        } else if caller(&name) {
            m.callers.push((addr, addr + s.size() as u32));
        }
    }
    Ok(m)
}

/// Frame boundaries in a firmware ([`frame_marks`]).
#[derive(Clone, Debug, Default)]
pub struct Marks {
    /// Entries of the frame's function.
    pub(super) starts: Vec<u32>,
    /// Address ranges of its callers.
    pub(super) callers: Vec<(u32, u32)>,
}
