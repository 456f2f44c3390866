//! A compact JSON document rendered on every thread and written in order.
//!
//! On a big level the .glb's JSON chunk is tens of megabytes, and serializing it on one thread
//! was most of the export. Here the document is a list of [`Source`]s in order; big arrays are
//! handed out a run of elements at a time, each run rendered into its own buffer by the thread
//! pool while this thread writes the buffers of the run before and finds the next runs. Compact
//! JSON has no state between elements but the comma, so the bytes are those a serializer writes
//! for the whole document in one pass. At most two windows of runs are held at once, a few
//! megabytes whatever the document's size.

use std::io::Write;
use std::ops::Range;

use crate::scene::json_text::{split_run, Elements};

/// Renders a part of the document into a buffer.
pub(crate) type Render<'r> = Box<dyn Fn(&mut Vec<u8>) -> serde_json::Result<()> + Send + Sync + 'r>;

/// Renders element `index` of an array from its text.
pub(crate) type RenderText<'r> =
    Box<dyn Fn(usize, &str, &mut Vec<u8>) -> serde_json::Result<()> + Send + Sync + 'r>;

/// Renders element `index` of an array known by its length.
pub(crate) type RenderItem<'r> =
    Box<dyn Fn(usize, &mut Vec<u8>) -> serde_json::Result<()> + Send + Sync + 'r>;

/// A part of the document, in order.
pub(crate) enum Source<'r> {
    Bytes(Vec<u8>),
    Job(Render<'r>),
    /// Rendered on the writing thread when the writer reaches it (a value another thread is
    /// still computing, which a render on the pool would wait for).
    Deferred(Box<dyn FnOnce() -> serde_json::Result<Vec<u8>> + 'r>),
    /// The elements of an array's text (between the brackets, which are sources of their own),
    /// each rendered by `render`, then `tail` as one more element if there is one.
    Text {
        elements: Elements<'r>,
        render: std::sync::Arc<RenderText<'r>>,
        tail: Option<Render<'r>>,
    },
    /// Elements `0..len` of an array (between its brackets).
    Items {
        len: usize,
        render: std::sync::Arc<RenderItem<'r>>,
    },
}

impl<'r> Source<'r> {
    pub fn bytes(b: &[u8]) -> Source<'r> {
        Source::Bytes(b.to_vec())
    }

    /// `"key":`, with a comma before it unless it is the first member.
    pub(crate) fn key(key: &str, first: bool) -> serde_json::Result<Source<'r>> {
        let mut b = Vec::with_capacity(key.len() + 4);
        if !first {
            b.push(b',');
        }
        serde_json::to_writer(&mut b, key)?;
        b.push(b':');
        Ok(Source::Bytes(b))
    }

    /// A value serialized as it is.
    pub(crate) fn value<T: serde::Serialize + Sync + ?Sized>(v: &'r T) -> Source<'r> {
        Source::Job(Box::new(move |b| serde_json::to_writer(b, v)))
    }
}

/// Text an element run of about this size is handed out as one piece of work.
const RUN: usize = 64 << 10;
/// Text a window of runs holds before it is written.
const WINDOW: usize = 2 << 20;
/// Runs of `Items` elements (cells, portals), whose text is not known beforehand.
const ITEMS: usize = 256;

/// One piece of work: bytes to write, or a render.
enum Piece<'r> {
    Bytes(Vec<u8>),
    Failed(std::sync::Mutex<Option<serde_json::Error>>),
    Job(Render<'r>),
    Run {
        text: &'r str,
        first: usize,
        render: std::sync::Arc<RenderText<'r>>,
    },
    Items {
        range: Range<usize>,
        render: std::sync::Arc<RenderItem<'r>>,
    },
}

impl Piece<'_> {
    fn render(&self, out: &mut Vec<u8>) -> serde_json::Result<()> {
        match self {
            Piece::Bytes(b) => {
                out.extend_from_slice(b);
                Ok(())
            }
            Piece::Job(r) => r(out),
            Piece::Failed(e) => Err(e
                .lock()
                .ok()
                .and_then(|mut e| e.take())
                .unwrap_or_else(|| serde::ser::Error::custom("a deferred part failed"))),
            Piece::Run {
                text,
                first,
                render,
            } => {
                for (k, e) in split_run(text).enumerate() {
                    if k > 0 {
                        out.push(b',');
                    }
                    render(first + k, e, out)?;
                }
                Ok(())
            }
            Piece::Items { range, render } => {
                for i in range.clone() {
                    if i > range.start {
                        out.push(b',');
                    }
                    render(i, out)?;
                }
                Ok(())
            }
        }
    }
}

/// Hands out the sources' pieces in order, a window at a time.
struct Pieces<'r> {
    sources: std::vec::IntoIter<Source<'r>>,
    current: Option<Source<'r>>,
    /// Whether the current array source handed out an element yet (the next run needs a comma).
    started: bool,
}

impl<'r> Pieces<'r> {
    /// The next pieces, about `window` bytes of text; empty when the document is done.
    fn window(&mut self, window: usize) -> Vec<Piece<'r>> {
        let mut out = Vec::new();
        let mut size = 0;
        while size < window {
            if self.current.is_none() {
                self.current = self.sources.next();
                self.started = false;
            }
            let piece = match &mut self.current {
                None => break,
                Some(Source::Bytes(b)) => {
                    size += b.len();
                    let b = std::mem::take(b);
                    self.current = None;
                    Piece::Bytes(b)
                }
                Some(Source::Deferred(_)) => {
                    let Some(Source::Deferred(f)) = self.current.take() else {
                        unreachable!()
                    };
                    match f() {
                        Ok(b) => {
                            size += b.len();
                            Piece::Bytes(b)
                        }
                        Err(e) => Piece::Failed(std::sync::Mutex::new(Some(e))),
                    }
                }
                Some(Source::Job(_)) => {
                    let Some(Source::Job(r)) = self.current.take() else {
                        unreachable!()
                    };
                    // A job's size is not known; count it as a run.
                    size += RUN;
                    Piece::Job(r)
                }
                Some(Source::Text {
                    elements,
                    render,
                    tail,
                }) => {
                    let first = elements.count;
                    match elements.run(RUN) {
                        Some((text, _)) => {
                            size += text.len();
                            Piece::Run {
                                text,
                                first,
                                render: render.clone(),
                            }
                        }
                        None => {
                            if let Some(tail) = tail.take() {
                                if self.started {
                                    out.push(Piece::Bytes(vec![b',']));
                                }
                                out.push(Piece::Job(tail));
                            }
                            self.current = None;
                            continue;
                        }
                    }
                }
                Some(Source::Items { len, render }) => {
                    let render = render.clone();
                    let len = *len;
                    let Some(Source::Items { .. }) = self.current.take() else {
                        unreachable!()
                    };
                    // Items are split here, all at once: their count is known.
                    for start in (0..len).step_by(ITEMS) {
                        if start > 0 {
                            out.push(Piece::Bytes(vec![b',']));
                        }
                        out.push(Piece::Items {
                            range: start..(start + ITEMS).min(len),
                            render: render.clone(),
                        });
                    }
                    size += RUN;
                    continue;
                }
            };
            if matches!(piece, Piece::Run { .. }) {
                if self.started {
                    out.push(Piece::Bytes(vec![b',']));
                }
                self.started = true;
            }
            out.push(piece);
        }
        out
    }
}

/// Why the document was not written: a render failed (the caller decides what that means), or
/// the output did.
pub(crate) enum Failure {
    Render(serde_json::Error),
    Io(std::io::Error),
}

/// Writes the sources to `w` in order, rendering them on the thread pool a window at a time.
pub(crate) fn write(sources: Vec<Source<'_>>, w: &mut dyn Write) -> Result<(), Failure> {
    let mut pieces = Pieces {
        sources: sources.into_iter(),
        current: None,
        started: false,
    };
    let mut window = pieces.window(WINDOW);
    let mut done: Vec<serde_json::Result<Vec<u8>>> = Vec::new();
    loop {
        if window.is_empty() && done.is_empty() {
            return Ok(());
        }
        let mut slots: Vec<Option<serde_json::Result<Vec<u8>>>> =
            (0..window.len()).map(|_| None).collect();
        let mut written = Ok(());
        let mut next = Vec::new();
        rayon::in_place_scope(|s| {
            for (piece, slot) in window.iter().zip(slots.iter_mut()) {
                s.spawn(move |_| {
                    let mut b = Vec::new();
                    *slot = Some(piece.render(&mut b).map(|()| b));
                });
            }
            written = done.drain(..).try_for_each(|b| match b {
                Ok(b) => w.write_all(&b).map_err(Failure::Io),
                Err(e) => Err(Failure::Render(e)),
            });
            if written.is_ok() {
                next = pieces.window(WINDOW);
            }
        });
        written?;
        done = slots.into_iter().flatten().collect();
        window = next;
    }
}

#[cfg(test)]
mod tests {
    use serde_json::{json, Value};

    use super::*;

    /// Sources over an array's text with each element copied: the whole document must come
    /// out as serde_json writes it, for runs of any size.
    #[test]
    fn the_same_bytes_as_one_serializer() {
        let items: Vec<Value> = (0..5000)
            .map(|i| json!({"name": format!("n\"{i}"), "v": [i, 0.5 * i as f64, {"x": []}]}))
            .collect();
        let text = serde_json::to_string_pretty(&items).unwrap();
        let numbers: Vec<u32> = (0..3000).collect();
        let mut with_tail = items.clone();
        with_tail.push(json!({"tail": true}));
        let doc = json!({"items": with_tail, "numbers": numbers, "empty": [7], "one": [1]});
        let want = serde_json::to_vec(&doc).unwrap();
        let copy = || -> std::sync::Arc<RenderText<'_>> {
            std::sync::Arc::new(Box::new(|_, e: &str, b: &mut Vec<u8>| {
                let v: Value = serde_json::from_str(e)?;
                serde_json::to_writer(b, &v)
            }))
        };
        let sources = vec![
            Source::bytes(b"{"),
            Source::key("items", true).unwrap(),
            Source::bytes(b"["),
            Source::Text {
                elements: Elements::of(&text).unwrap(),
                render: copy(),
                tail: Some(Box::new(|b| {
                    serde_json::to_writer(b, &json!({"tail": true}))
                })),
            },
            Source::bytes(b"]"),
            Source::key("numbers", false).unwrap(),
            Source::bytes(b"["),
            Source::Items {
                len: numbers.len(),
                render: std::sync::Arc::new(Box::new(|i, b: &mut Vec<u8>| {
                    serde_json::to_writer(b, &numbers[i])
                })),
            },
            Source::bytes(b"]"),
            Source::key("empty", false).unwrap(),
            Source::bytes(b"["),
            Source::Text {
                elements: Elements::of(" [ ] ").unwrap(),
                render: copy(),
                tail: Some(Box::new(|b| serde_json::to_writer(b, &7))),
            },
            Source::bytes(b"]"),
            Source::key("one", false).unwrap(),
            Source::value(&doc["one"]),
            Source::bytes(b"}"),
        ];
        let mut got = Vec::new();
        assert!(write(sources, &mut got).is_ok());
        assert_eq!(
            String::from_utf8(got).unwrap(),
            String::from_utf8(want).unwrap()
        );
    }
}
