//! Reading a photometric file: the format is told from the content, then the LM-63 reader
//! (`ies`) or the EULUMDAT reader (`ldt`) builds the [`Photometry`].

use crate::{IesError, ParseOptions, Photometry};

impl Photometry {
    /// Reads an IES LM-63 file (any version) or an EULUMDAT file, detected from the content,
    /// with default [`Limits`](crate::Limits). A `TILT=<file>` line is an error
    /// ([`IesError::TiltFileUnresolved`]); use [`Photometry::parse_with`] and a resolver.
    pub fn parse(bytes: &[u8]) -> Result<Photometry, IesError> {
        Photometry::parse_with(bytes, &ParseOptions::default())
    }

    /// Reads a file with explicit limits and a `TILT=<file>` resolver.
    ///
    /// A file is LM-63 when its first non-blank line starts with `IESNA` or `IES:` or when any
    /// line starts with `TILT`; otherwise it is read as EULUMDAT.
    pub fn parse_with(bytes: &[u8], options: &ParseOptions) -> Result<Photometry, IesError> {
        let limits = &options.limits;
        if bytes.len() > limits.max_bytes {
            return Err(IesError::TooLarge {
                size: bytes.len(),
                limit: limits.max_bytes,
            });
        }
        let text = crate::text::decode(bytes);
        if text.trim().is_empty() {
            return Err(IesError::Empty);
        }
        let lines = crate::text::lines(&text);
        let first = lines.iter().map(|l| l.trim()).find(|l| !l.is_empty());
        let is_ies = first.is_some_and(|l| {
            let up = l.to_ascii_uppercase();
            up.starts_with("IESNA") || up.starts_with("IES:")
        }) || lines
            .iter()
            .any(|l| l.trim_start().to_ascii_uppercase().starts_with("TILT"));
        if is_ies {
            crate::ies::parse(&lines, options)
        } else {
            crate::ldt::parse(&lines, limits)
        }
    }
}
