//! Python exceptions carrying lcpbench's messages: [`LcpbenchError`] (a `ValueError`) for bad
//! data and options, `OSError` and its subclasses for files that cannot be read or written.

use lcpbench_solvers::ProblemFileError;
use pyo3::exceptions::{
    PyFileExistsError, PyFileNotFoundError, PyOSError, PyPermissionError, PyValueError,
};
use pyo3::PyErr;

pyo3::create_exception!(
    lcpbench,
    LcpbenchError,
    PyValueError,
    "Bad input to lcpbench: the message names the file or argument, the field and the limit."
);

/// An [`LcpbenchError`] with `message`.
pub fn bad(message: impl Into<String>) -> PyErr {
    LcpbenchError::new_err(message.into())
}

/// An `OSError` (`FileNotFoundError`, `PermissionError`, `FileExistsError` where they apply) with `message`.
pub fn os_error(kind: std::io::ErrorKind, message: String) -> PyErr {
    match kind {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
        std::io::ErrorKind::AlreadyExists => PyFileExistsError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// A problem-file error as a Python exception: I/O failures as `OSError`, everything else
/// (parse errors, bad fields, invalid data, unsupported variants) as [`LcpbenchError`].
pub fn file_error(e: ProblemFileError) -> PyErr {
    match &e {
        ProblemFileError::Io { source, .. } => os_error(source.kind(), e.to_string()),
        _ => bad(e.to_string()),
    }
}
