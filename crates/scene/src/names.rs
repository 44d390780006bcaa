//! Enums named by lower-case words (the CLI's and the scene files'): parsing a name back.

/// The value of `all` whose `name` is `s` (trimmed, case-insensitive), else an error that
/// lists every name: `expected "a", "b" or "c", got `s``.
pub(crate) fn parse_name<T: Copy>(
    s: &str,
    all: &[T],
    name: fn(T) -> &'static str,
) -> Result<T, String> {
    let wanted = s.trim().to_ascii_lowercase();
    if let Some(&v) = all.iter().find(|&&v| name(v) == wanted) {
        return Ok(v);
    }
    let quoted: Vec<String> = all.iter().map(|&v| format!("\"{}\"", name(v))).collect();
    let expected = match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    Err(format!("expected {expected}, got `{s}`"))
}

/// `FromStr` for enums with `ALL` and `name()`: [`parse_name`] of every value's name.
macro_rules! from_str_by_name {
    ($($t:ty),*) => {$(
        impl std::str::FromStr for $t {
            type Err = String;
            /// One of the names of every value (case-insensitive).
            fn from_str(s: &str) -> Result<$t, String> {
                $crate::names::parse_name(s, &<$t>::ALL, <$t>::name)
            }
        }
    )*};
}

pub(crate) use from_str_by_name;
