//! What a record keeps of a host's words about a mesh (what its file held that the mesh does
//! not keep, what the mesh carries): a mesh has a few such things, each in a few words.

const MAX_ENTRIES: usize = 32;
const MAX_ENTRY_CHARS: usize = 200;

/// A host's words, kept short, so a lying host cannot swell the record.
pub(super) fn bounded_words(words: &[String]) -> Vec<String> {
    (words.iter().take(MAX_ENTRIES))
        .map(|what| what.chars().take(MAX_ENTRY_CHARS).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hosts_list_of_words_about_a_mesh_is_bounded() {
        let lying: Vec<String> = (0..1000).map(|_| "é".repeat(10_000)).collect();
        let kept = bounded_words(&lying);
        assert_eq!(kept.len(), MAX_ENTRIES);
        assert!(kept.iter().all(|what| what.chars().count() == MAX_ENTRY_CHARS));
        let honest = vec!["vertex colour (red, green, blue)".to_owned()];
        assert_eq!(bounded_words(&honest), honest);
    }
}
