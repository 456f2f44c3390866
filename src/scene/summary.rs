//! A scene summary for `inspect`.
