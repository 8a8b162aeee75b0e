//! Did-you-mean: the known name closest to a misspelt one.

/// Names further than this from what was typed (Damerau–Levenshtein edits, and at most
/// a third of the typed name) are not suggested: a suggestion should look like a typo's fix.
pub const MAX_SUGGESTION_EDITS: usize = 3;

/// The candidate closest to `typed`, if close enough to be a likely typo; ties go to the
/// first candidate.
pub fn closest<'a>(typed: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = MAX_SUGGESTION_EDITS.min(typed.chars().count().div_ceil(3)).max(1);
    candidates
        .into_iter()
        .map(|name| (strsim::damerau_levenshtein(typed, name), name))
        .filter(|(distance, _)| *distance <= limit)
        .min_by_key(|(distance, _)| *distance)
        .map(|(_, name)| name)
}

/// `"; did you mean \"NAME\"?"` when a candidate is close to `typed`, else nothing.
pub fn did_you_mean<'a>(typed: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    closest(typed, candidates).map(|name| format!("; did you mean \"{name}\"?")).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    const SERVICES: [&str; 4] =
        ["laplacian-smoothing", "fill-holes", "hole-count", "remove-smallest-components"];

    #[test]
    fn typos_get_the_intended_name() {
        assert_eq!(closest("laplacian-smothing", SERVICES), Some("laplacian-smoothing"));
        assert_eq!(closest("fill-hoels", SERVICES), Some("fill-holes"));
        assert_eq!(closest("hole-cuont", SERVICES), Some("hole-count"));
        assert_eq!(did_you_mean("fil-holes", SERVICES), "; did you mean \"fill-holes\"?");
    }

    #[test]
    fn unrelated_names_get_no_suggestion() {
        assert_eq!(closest("sharpen", SERVICES), None);
        assert_eq!(closest("x", SERVICES), None);
        assert_eq!(did_you_mean("decimate", SERVICES), "");
    }
}
