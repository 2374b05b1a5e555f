//! What seed-file messages suggest: the nearest known key or joint name, likely parents, how to
//! write a missing key, and short excerpts of what was found.

/// 1-based line holding byte `offset` of `bytes`.
pub(super) fn line_of_offset(bytes: &[u8], offset: usize) -> usize {
    let end = offset.min(bytes.len());
    bytes[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// Levenshtein distance between `a` and `b`, ignoring ASCII case.
pub(super) fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().map(|c| c.to_ascii_lowercase()).collect();
    let b: Vec<char> = b.chars().map(|c| c.to_ascii_lowercase()).collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.iter().enumerate() {
        cur[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The candidate nearest to `word`, if it is close enough to be a likely typo.
pub(super) fn nearest<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (edit_distance(word, c), c))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// `; did you mean `x`?` or nothing.
pub(super) fn did_you_mean_key(word: &str, candidates: &[&str]) -> String {
    nearest(word, candidates.iter().copied())
        .map(|c| format!("; did you mean `{c}`?"))
        .unwrap_or_default()
}

/// A short excerpt of source text, for "found ..." in messages.
pub(super) fn excerpt(s: &str) -> String {
    let s = s.trim();
    let mut out: String = s.chars().take(40).collect();
    if out.len() < s.len() {
        out.push('…');
    }
    out
}

/// Joint names the user may have meant by the unknown parent `p`: the nearest name if it is a
/// likely typo, else the names whose last part (after `.`, `_` or `-`) is `p`, such as
/// "female.head" and "male.head" for "head".
pub(super) fn parent_guesses<'a>(p: &str, names: &'a [String]) -> Vec<&'a str> {
    if let Some(g) = nearest(p, names.iter().map(String::as_str)) {
        return vec![g];
    }
    names
        .iter()
        .map(String::as_str)
        .filter(|n| {
            n.strip_suffix(p)
                .is_some_and(|head| head.ends_with(['.', '_', '-']))
        })
        .take(5)
        .collect()
}

/// How to write a missing required key.
pub(super) fn required_hint(key: &str) -> &'static str {
    match key {
        "x" | "y" => {
            "give the rectangle centre in px as x = ... and y = ... (origin top-left, y down)"
        }
        "w" | "h" => "give the rectangle size in whole px as w = ... and h = ... (at least 5)",
        _ => "add it",
    }
}

/// Up to 12 names, quoted, then how many more.
pub(super) fn list_names(names: &[String]) -> String {
    const SHOWN: usize = 12;
    let mut s: Vec<String> = names.iter().take(SHOWN).map(|n| format!("{n:?}")).collect();
    if names.len() > SHOWN {
        s.push(format!("and {} more", names.len() - SHOWN));
    }
    s.join(", ")
}
