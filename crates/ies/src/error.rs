//! The crate's one error type.

use thiserror::Error;

/// Everything that can go wrong while reading a photometric file.
///
/// Line numbers are 1-based and refer to the input as given (after decoding to text). `expected`
/// says in words what the parser was looking for at that point.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum IesError {
    /// The input holds no text at all.
    #[error("the input is empty")]
    Empty,
    /// The input is larger than [`Limits::max_bytes`](crate::Limits::max_bytes).
    #[error("the input is {size} bytes, over the limit of {limit} bytes")]
    TooLarge {
        /// Size of the input in bytes.
        size: usize,
        /// The limit in force.
        limit: usize,
    },
    /// The file ended where more data was required.
    #[error("line {line}: unexpected end of file, expected {expected}")]
    UnexpectedEof {
        /// Line of the last value read (or the last line of the file).
        line: usize,
        /// What was still missing.
        expected: String,
    },
    /// A token could not be read as what was expected (not a number, not an integer, …).
    #[error("line {line}: expected {expected}, found `{found}`")]
    Syntax {
        /// Line of the offending token.
        line: usize,
        /// What was expected.
        expected: String,
        /// The offending text (shortened to at most 40 characters).
        found: String,
    },
    /// A value was read but is not allowed (negative count, unknown type, angle out of range, …).
    #[error("line {line}: {what} is {value}, expected {expected}")]
    OutOfRange {
        /// Line of the value.
        line: usize,
        /// Which field.
        what: String,
        /// The value found.
        value: f64,
        /// The allowed range, in words.
        expected: String,
    },
    /// Angles that must be strictly increasing are not.
    #[error("line {line}: {what} must be strictly increasing, but {next} follows {previous}")]
    NotIncreasing {
        /// Line of the offending angle.
        line: usize,
        /// Which list of angles.
        what: String,
        /// The angle before.
        previous: f64,
        /// The angle that is not larger.
        next: f64,
    },
    /// A count in the file is larger than the [`Limits`](crate::Limits) allow.
    #[error("line {line}: {what} is {count}, over the limit of {limit}")]
    LimitExceeded {
        /// Line of the count.
        line: usize,
        /// Which count.
        what: String,
        /// The count requested by the file.
        count: u64,
        /// The limit in force.
        limit: u64,
    },
    /// An LM-63 file has no `TILT=` line.
    #[error("no `TILT=` line found: not an IES LM-63 file, or its header is truncated")]
    MissingTilt,
    /// `TILT=<file>` names a file and no resolver was given, or the resolver could not find it.
    #[error(
        "line {line}: TILT={name} refers to a separate tilt file that could not be resolved \
         (pass a tilt resolver in ParseOptions)"
    )]
    TiltFileUnresolved {
        /// Line of the `TILT=` line.
        line: usize,
        /// The file name as written.
        name: String,
    },
    /// The separate tilt file named by `TILT=<file>` is malformed.
    #[error("tilt file `{name}`: {source}")]
    TiltFile {
        /// The file name as written.
        name: String,
        /// What is wrong inside it (line numbers refer to the tilt file).
        source: Box<IesError>,
    },
    /// The horizontal (or, for EULUMDAT, C-plane) angles describe no symmetry LM-63 knows.
    #[error("line {line}: {detail}")]
    UnsupportedAngles {
        /// Line of the horizontal angles.
        line: usize,
        /// What is wrong, in words.
        detail: String,
    },
}

impl IesError {
    /// The 1-based line number the error refers to, when there is one.
    pub fn line(&self) -> Option<usize> {
        match self {
            IesError::UnexpectedEof { line, .. }
            | IesError::Syntax { line, .. }
            | IesError::OutOfRange { line, .. }
            | IesError::NotIncreasing { line, .. }
            | IesError::LimitExceeded { line, .. }
            | IesError::TiltFileUnresolved { line, .. }
            | IesError::UnsupportedAngles { line, .. } => Some(*line),
            IesError::Empty
            | IesError::TooLarge { .. }
            | IesError::MissingTilt
            | IesError::TiltFile { .. } => None,
        }
    }
}
