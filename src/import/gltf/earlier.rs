//! What an earlier annotation by portcullis appended to the document: its PVS's buffer view,
//! its split indices' view and accessor, and their bytes. A file converted again (`convert
//! --in-place`, a CI step run on its own output) drops them before the new annotation appends
//! its own, so it keeps its size and its bytes are those of the first conversion. Only what is
//! still the document's tail, used by nothing else, and in bytes the output rewrites (a GLB's
//! BIN chunk, a data: URI) is dropped; anything else is kept as it is.

use super::schema::Doc;
use crate::scene::Earlier;

/// The earlier annotation's tail in `doc`, whose buffers hold `lens` bytes; `None` when there
/// is none or it cannot be told apart from the rest.
pub(crate) fn of(doc: &Doc, lens: &[usize]) -> Option<Earlier> {
    let (pvs, split) = doc.stored_appended;
    let split = split.map(usize::try_from).transpose().ok()?;
    let split_view = match split {
        Some(a) => {
            // The accessor is the last, over a view of its own, and no primitive reads it.
            let acc = doc
                .accessors
                .get(a)
                .filter(|_| a + 1 == doc.accessors.len())?;
            let used = (doc.meshes.iter())
                .flat_map(|m| m.primitives.iter().flatten())
                .any(|p| {
                    p.indices == Some(a as u64)
                        || p.attributes.as_ref().and_then(|t| t.position) == Some(a as u64)
                });
            if used || acc.sparse.is_some() {
                return None;
            }
            Some(usize::try_from(acc.buffer_view?).ok()?)
        }
        None => None,
    };
    let pvs = pvs.map(usize::try_from).transpose().ok()?;
    let mut ours: Vec<usize> = pvs.into_iter().chain(split_view).collect();
    if ours.is_empty() {
        return None;
    }
    ours.sort_unstable();
    ours.dedup();
    // Views: the last ones, one after another.
    let views = ours[0];
    if ours.iter().enumerate().any(|(i, &v)| v != views + i)
        || views + ours.len() != doc.buffer_views.len()
    {
        return None;
    }
    let accessors = split.unwrap_or(doc.accessors.len());
    let seen_by_others = doc.accessors[..accessors].iter().any(|a| {
        let sparse = a.sparse.as_ref();
        [
            a.buffer_view,
            sparse.and_then(|s| s.indices.as_ref()?.buffer_view),
            sparse.and_then(|s| s.values.as_ref()?.buffer_view),
        ]
        .into_iter()
        .flatten()
        .any(|v| v >= views as u64)
    });
    if seen_by_others {
        return None;
    }
    // Bytes: one buffer holds them, rewritten by the output, and nothing else of it lies past
    // where they start.
    let buffer_of = |v: usize| usize::try_from(doc.buffer_views[v].buffer?).ok();
    let buffer = buffer_of(views)?;
    if ours.iter().any(|&v| buffer_of(v) != Some(buffer)) {
        return None;
    }
    let b = doc.buffers.get(buffer)?;
    if b.uri.as_deref().is_some_and(|u| !u.starts_with("data:")) {
        return None;
    }
    let start = ours
        .iter()
        .map(|&v| doc.buffer_views[v].byte_offset)
        .min()? as usize;
    let others = (doc.buffer_views[..views].iter()).filter(|v| v.buffer == Some(buffer as u64));
    let mut others_end = None;
    for v in others {
        let end = v.byte_offset.checked_add(v.byte_length?)? as usize;
        others_end = Some(others_end.unwrap_or(0).max(end));
    }
    if others_end.is_some_and(|e| e > start) || start > *lens.get(buffer)? {
        return None;
    }
    let cut = match others_end {
        // A buffer of its own, the last: dropped.
        None if buffer + 1 == doc.buffers.len() => (buffer, None),
        None => return None,
        Some(_) => (buffer, Some(start)),
    };
    Some(Earlier {
        views,
        accessors,
        cut,
    })
}
