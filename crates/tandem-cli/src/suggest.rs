//! "Did you mean …?" suggestions for misspelled names.

/// The candidate closest to `word` if it is close enough to be a likely misspelling: an edit
/// distance (with transpositions) of at most 1 for short words, 2 up to 8 characters, 3 beyond;
/// ties go to the first candidate. Case is ignored.
pub fn closest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let w = word.to_lowercase();
    let limit = match w.chars().count() {
        0..=3 => 1,
        4..=8 => 2,
        _ => 3,
    };
    candidates
        .into_iter()
        .map(|c| (strsim::damerau_levenshtein(&w, &c.to_lowercase()), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::closest;

    #[test]
    fn suggests_close_names_only() {
        let fields = ["mass", "length", "com", "inertia"];
        assert_eq!(closest("masss", fields), Some("mass"));
        assert_eq!(closest("lenght", fields), Some("length"));
        assert_eq!(closest("intertia", fields), Some("inertia"));
        assert_eq!(closest("colour", fields), None);
        assert_eq!(closest("papr", ["paper", "push"]), Some("paper"));
    }
}
