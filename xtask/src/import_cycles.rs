//! Test: no circle of imports between the source files of any crate under `crates/`.
//!
//! Every `.rs` file under `crates/*/src` is one module. A file *imports* another when one of
//! its `use` declarations, or a `crate::…`, `super::…`, `self::…` or `child_module::…` path in
//! its code, names an item of the other file. Re-exports (`pub use x::Item`, as in a crate
//! root) are followed to the file that defines the item rather than counted as imports of the
//! re-exporting file. `mod child;` alone imports nothing: an `impl` block in a child module
//! does not make its parent depend on it. Unit tests (`#[cfg(test)]` items and files) are left
//! out, as cargo allows cycles through dev-dependencies. Comments, strings and inline modules
//! (`mod tests { use super::*; }` stays within its file) are handled.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module path inside a crate: `[]` is the root, `["output", "picture"]` a nested file.
type ModPath = Vec<String>;

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Sep,
    /// `{ } , ; * ( ) [ ] #`
    Punct(char),
    /// Any other punctuation (it ends a path).
    Other,
}

/// The tokens of `src` that matter for paths: comments, strings and char literals dropped.
fn lex(src: &str) -> Vec<Tok> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
        } else if ch == '\'' {
            // A char literal ('x', '\n', '{') or a lifetime ('a).
            if c.get(i + 1) == Some(&'\\') {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
            }
        } else if ch.is_alphanumeric() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            // Raw strings: r"…", r#"…"#, br#"…"#.
            if (word == "r" || word == "br") && matches!(c.get(i), Some('"' | '#')) {
                let hashes = c[i..].iter().take_while(|&&h| h == '#').count();
                if c.get(i + hashes) == Some(&'"') {
                    i += hashes + 1;
                    while i < c.len() {
                        if c[i] == '"' && c[i + 1..].iter().take(hashes).all(|&h| h == '#') {
                            i += 1 + hashes;
                            break;
                        }
                        i += 1;
                    }
                    continue;
                }
            }
            out.push(Tok::Ident(word));
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push(Tok::Sep);
            i += 2;
        } else {
            out.push(if "{},;*()[]#".contains(ch) {
                Tok::Punct(ch)
            } else {
                Tok::Other
            });
            i += 1;
        }
    }
    out
}

/// What one file says about paths: every path it names (absolute, from the crate root) and
/// its re-exports (`pub use`: the name it binds → the absolute path it names).
#[derive(Debug, Default)]
struct FileRefs {
    paths: Vec<ModPath>,
    reexports: BTreeMap<String, ModPath>,
    /// Child file modules declared `#[cfg(test)] mod name;`.
    test_children: Vec<String>,
}

/// The paths named by the tokens of the file at module path `file`.
fn file_refs(toks: &[Tok], file: &ModPath) -> FileRefs {
    let children = child_modules(toks);
    let mut refs = FileRefs::default();
    // Inline modules open at brace depth: (name, depth of their `{`).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < toks.len() {
        let here: ModPath = file
            .iter()
            .cloned()
            .chain(inline.iter().map(|(n, _)| n.clone()))
            .collect();
        let local = inline.is_empty();
        if is_cfg_test(&toks[i..]) {
            i = skip_group(toks, i + 1);
            while toks.get(i) == Some(&Tok::Punct('#')) {
                i = skip_group(toks, i + 1);
            }
            if let (Some(Tok::Ident(m)), Some(Tok::Ident(name)), Some(Tok::Punct(';'))) =
                (toks.get(i), toks.get(i + 1), toks.get(i + 2))
                && m == "mod"
            {
                refs.test_children.push(name.clone());
            }
            i = skip_item(toks, i);
            continue;
        }
        match &toks[i] {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => {
                if inline.last().is_some_and(|&(_, d)| d == depth) {
                    inline.pop();
                }
                depth = depth.saturating_sub(1);
            }
            Tok::Ident(w) if w == "mod" => {
                if let (Some(Tok::Ident(name)), Some(Tok::Punct('{'))) =
                    (toks.get(i + 1), toks.get(i + 2))
                {
                    depth += 1;
                    inline.push((name.clone(), depth));
                    i += 3;
                    continue;
                }
            }
            Tok::Ident(w) if w == "use" => {
                let public = is_pub(&toks[..i]);
                let mut uses = Vec::new();
                i = use_tree(toks, i + 1, Vec::new(), &mut uses);
                for (path, binding) in uses {
                    let children = if local { &children[..] } else { &[] };
                    let Some(abs) = absolute(&path, &here, children) else {
                        continue;
                    };
                    match binding {
                        Some(name) if public => drop(refs.reexports.insert(name, abs)),
                        _ => refs.paths.push(abs),
                    }
                }
                continue;
            }
            Tok::Ident(w) if !matches!(i.checked_sub(1).map(|p| &toks[p]), Some(Tok::Sep)) => {
                let starts = matches!(w.as_str(), "crate" | "super" | "self")
                    || (local && children.contains(w));
                if starts && toks.get(i + 1) == Some(&Tok::Sep) {
                    let mut path = vec![w.clone()];
                    let mut j = i + 1;
                    while let (Some(Tok::Sep), Some(Tok::Ident(n))) = (toks.get(j), toks.get(j + 1))
                    {
                        path.push(n.clone());
                        j += 2;
                    }
                    let children = if local { &children[..] } else { &[] };
                    if let Some(abs) = absolute(&path, &here, children) {
                        refs.paths.push(abs);
                    }
                    i = j;
                    continue;
                }
            }
            _ => {}
        }
        i += 1;
    }
    refs
}

/// Whether `toks` starts with `#[cfg(test)]`: the item after it is a unit test, left out
/// like a dev-dependency.
fn is_cfg_test(toks: &[Tok]) -> bool {
    match toks {
        [
            Tok::Punct('#'),
            Tok::Punct('['),
            Tok::Ident(c),
            Tok::Punct('('),
            Tok::Ident(t),
            Tok::Punct(')'),
            Tok::Punct(']'),
            ..,
        ] => c == "cfg" && t == "test",
        _ => false,
    }
}

/// Index after the bracketed group starting at `i` (`[…]`, `{…}` or `(…)`), nesting counted.
fn skip_group(toks: &[Tok], mut i: usize) -> usize {
    let mut depth = 0usize;
    while let Some(t) = toks.get(i) {
        i += 1;
        match t {
            Tok::Punct('[' | '{' | '(') => depth += 1,
            Tok::Punct(']' | '}' | ')') => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    break;
                }
            }
            _ => {}
        }
    }
    i
}

/// Index after the item starting at `i`: after its `;`, or after its `{…}` body.
fn skip_item(toks: &[Tok], mut i: usize) -> usize {
    while let Some(t) = toks.get(i) {
        match t {
            Tok::Punct(';') => return i + 1,
            Tok::Punct('{') => return skip_group(toks, i),
            _ => i += 1,
        }
    }
    i
}

/// The names of the file modules a file declares at its top level (`mod x;`).
fn child_modules(toks: &[Tok]) -> Vec<String> {
    let mut depth = 0usize;
    let mut out = Vec::new();
    for (i, t) in toks.iter().enumerate() {
        match t {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => depth = depth.saturating_sub(1),
            Tok::Ident(w) if w == "mod" && depth == 0 => {
                if let (Some(Tok::Ident(n)), Some(Tok::Punct(';'))) =
                    (toks.get(i + 1), toks.get(i + 2))
                {
                    out.push(n.clone());
                }
            }
            _ => {}
        }
    }
    out
}

/// Whether the `use` after `before` is `pub` or `pub(…)`.
fn is_pub(before: &[Tok]) -> bool {
    match before {
        [.., Tok::Ident(p)] => p == "pub",
        [.., Tok::Ident(p), Tok::Punct('('), _, Tok::Punct(')')] => p == "pub",
        _ => false,
    }
}

/// Parses the use tree starting at `i` under `prefix`; pushes (path, bound name) per leaf
/// (`None` for a glob). Returns the index after the tree (after `;` at the top level).
fn use_tree(
    toks: &[Tok],
    mut i: usize,
    mut prefix: ModPath,
    out: &mut Vec<(ModPath, Option<String>)>,
) -> usize {
    loop {
        match toks.get(i) {
            Some(Tok::Ident(w)) => {
                prefix.push(w.clone());
                i += 1;
            }
            Some(Tok::Sep) => i += 1,
            Some(Tok::Punct('*')) => {
                out.push((prefix, None));
                return i + 1;
            }
            Some(Tok::Punct('{')) => {
                i += 1;
                loop {
                    match toks.get(i) {
                        Some(Tok::Punct('}')) => return i + 1,
                        Some(Tok::Punct(',')) => i += 1,
                        Some(_) => i = use_tree(toks, i, prefix.clone(), out),
                        None => return i,
                    }
                }
            }
            _ => {
                // End of this leaf: `,`, `}`, `;` or `as alias`.
                let mut binding = prefix.last().cloned();
                if prefix.len() >= 2 && prefix[prefix.len() - 2] == "as" {
                    binding = prefix.pop();
                    prefix.pop();
                }
                if binding.as_deref() == Some("self") {
                    prefix.pop();
                    binding = prefix.last().cloned();
                }
                out.push((prefix, binding));
                return if toks.get(i) == Some(&Tok::Punct(';')) {
                    i + 1
                } else {
                    i
                };
            }
        }
    }
}

/// `path` as written in the module `here` → from the crate root; `None` for other crates.
fn absolute(path: &[String], here: &[String], children: &[String]) -> Option<ModPath> {
    let first = path.first()?;
    let mut base: ModPath = match first.as_str() {
        "crate" => Vec::new(),
        "self" | "super" => here.to_vec(),
        name if children.iter().any(|c| c == name) => here.to_vec(),
        _ => return None,
    };
    let mut rest = match first.as_str() {
        "crate" | "self" => &path[1..],
        _ => path,
    };
    while let Some((s, tail)) = rest.split_first()
        && s == "super"
    {
        base.pop()?;
        rest = tail;
    }
    base.extend(rest.iter().cloned());
    Some(base)
}

/// The file that defines what `path` names: the deepest file module on the path, through
/// re-exports.
fn defining_file<'a>(
    path: &[String],
    files: &'a BTreeMap<ModPath, FileRefs>,
    hops: usize,
) -> Option<&'a ModPath> {
    let (k, (module, refs)) = (0..=path.len())
        .rev()
        .find_map(|k| files.get_key_value(&path[..k]).map(|f| (k, f)))?;
    match path.get(k).and_then(|name| refs.reexports.get(name)) {
        Some(target) if hops < 8 => {
            let mut t = target.clone();
            t.extend(path[k + 1..].iter().cloned());
            defining_file(&t, files, hops + 1).or(Some(module))
        }
        _ => Some(module),
    }
}

/// The import edges of one crate: module path → the module paths it imports. Test-only
/// files (`#[cfg(test)] mod name;`) are left out.
fn edges(sources: &BTreeMap<ModPath, String>) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
    let mut files: BTreeMap<ModPath, FileRefs> = sources
        .iter()
        .map(|(m, src)| (m.clone(), file_refs(&lex(src), m)))
        .collect();
    let tests: Vec<ModPath> = files
        .iter()
        .flat_map(|(m, refs)| {
            refs.test_children
                .iter()
                .map(|c| [&m[..], std::slice::from_ref(c)].concat())
        })
        .collect();
    files.retain(|m, _| !tests.iter().any(|t| m.starts_with(t)));
    files
        .iter()
        .map(|(m, refs)| {
            let to = refs
                .paths
                .iter()
                .filter_map(|p| defining_file(p, &files, 0))
                .filter(|t| *t != m)
                .cloned()
                .collect();
            (m.clone(), to)
        })
        .collect()
}

/// The shortest cycle through each file that has one, each set of files reported once, as a
/// list of modules with the first repeated at the end.
fn cycles(edges: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<ModPath>> {
    let mut seen: BTreeSet<BTreeSet<&ModPath>> = BTreeSet::new();
    let mut out = Vec::new();
    for start in edges.keys() {
        // Breadth-first from `start` until an edge leads back to it.
        let mut parent: BTreeMap<&ModPath, &ModPath> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        let mut back = None;
        while let Some(m) = queue.pop_front() {
            let targets = edges.get(m).into_iter().flatten();
            if targets.clone().any(|t| t == start) {
                back = Some(m);
                break;
            }
            for t in targets {
                if t != start && !parent.contains_key(t) {
                    parent.insert(t, m);
                    queue.push_back(t);
                }
            }
        }
        let Some(mut c) = back else { continue };
        let mut chain = vec![c];
        while c != start {
            c = parent[c];
            chain.push(c);
        }
        chain.reverse();
        if seen.insert(chain.iter().copied().collect()) {
            out.push(chain.into_iter().chain([start]).cloned().collect());
        }
    }
    out
}

/// Module path of a file relative to its `src` folder.
fn module_path(rel: &Path) -> ModPath {
    let mut parts: ModPath = rel
        .with_extension("")
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod")) {
        parts.pop();
    }
    if parts.len() == 1 && matches!(parts[0].as_str(), "lib" | "main") {
        parts.clear();
    }
    parts
}

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rs_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn file_name(src_dir: &Path, m: &ModPath, root: &Path) -> String {
    let base = src_dir.strip_prefix(root).unwrap_or(src_dir);
    for candidate in [
        if m.is_empty() {
            PathBuf::from("lib.rs")
        } else {
            PathBuf::from(m.join("/") + ".rs")
        },
        PathBuf::from(m.join("/")).join("mod.rs"),
        PathBuf::from("main.rs"),
    ] {
        if src_dir.join(&candidate).is_file() {
            return base.join(candidate).display().to_string();
        }
    }
    format!("{}::{}", base.display(), m.join("::"))
}

#[test]
fn no_crate_has_a_cycle_of_imports_between_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root");
    let mut src_dirs: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .expect("crates/")
        .flatten()
        .map(|e| e.path().join("src"))
        .filter(|p| p.is_dir())
        .collect();
    src_dirs.sort();
    let (mut file_count, mut edge_count) = (0, 0);
    let mut found = Vec::new();
    for dir in &src_dirs {
        let mut paths = Vec::new();
        rs_files(dir, &mut paths);
        let sources: BTreeMap<ModPath, String> = paths
            .iter()
            .map(|p| {
                let rel = p.strip_prefix(dir).expect("under src");
                let text = std::fs::read_to_string(p).expect("readable source");
                (module_path(rel), text)
            })
            .collect();
        file_count += sources.len();
        let e = edges(&sources);
        edge_count += e.values().map(BTreeSet::len).sum::<usize>();
        for cycle in cycles(&e) {
            let names: Vec<String> = cycle.iter().map(|m| file_name(dir, m, root)).collect();
            found.push(names.join(" → "));
        }
    }
    println!("{file_count} files, {edge_count} import edges between them");
    assert!(file_count > 60, "only {file_count} source files found");
    assert!(edge_count > 100, "only {edge_count} import edges found");
    assert!(found.is_empty(), "import cycles:\n  {}", found.join("\n  "));
}

#[test]
fn the_checker_sees_uses_paths_and_reexports() {
    let crate_of = |files: &[(&[&str], &str)]| -> BTreeMap<ModPath, String> {
        files
            .iter()
            .map(|(m, s)| (m.iter().map(|x| x.to_string()).collect(), s.to_string()))
            .collect()
    };
    let m = |p: &[&str]| -> ModPath { p.iter().map(|x| x.to_string()).collect() };
    let src = crate_of(&[
        (&[], "mod a; mod b; mod c; pub use a::{A, Apple as Ap};\n"),
        (
            &["a"],
            "//! crate::c::X in a comment\nuse crate::b::{self, B};\nconst S: &str = \"crate::c::\";\n",
        ),
        (
            &["b"],
            "fn f() { let c = '{'; crate::Ap::new(); }\nmod inner { use super::*; }\n#[cfg(test)]\nmod tests { use crate::c::X; }\n#[cfg(test)]\nmod t;\n",
        ),
        (&["b", "t"], "use crate::c::Y;\n"),
        (
            &["c"],
            "pub(crate) use crate::A;\nmod d;\nfn g() { d::h(); }\n",
        ),
        (&["c", "d"], "use super::super::b::*;\n"),
    ]);
    let e = edges(&src);
    assert_eq!(
        e[&m(&[])],
        BTreeSet::new(),
        "re-exports are followed, not imports"
    );
    assert_eq!(e[&m(&["a"])], BTreeSet::from([m(&["b"])]));
    assert_eq!(
        e[&m(&["b"])],
        BTreeSet::from([m(&["a"])]),
        "through the root's re-export"
    );
    assert_eq!(e[&m(&["c"])], BTreeSet::from([m(&["c", "d"])]));
    assert_eq!(e[&m(&["c", "d"])], BTreeSet::from([m(&["b"])]));
    assert_eq!(cycles(&e), vec![vec![m(&["a"]), m(&["b"]), m(&["a"])]]);
}
