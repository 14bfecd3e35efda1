//! Listing the sessions of a dataset laid out like `eyereplay prepare`
//! writes it (the driver that renders them is eyereplay-backends').

use eyereplay_render::*;

#[test]
fn each_class_takes_the_shared_choices_in_turn() {
    // 7 reading and 5 conversation sessions, interleaved in labels.csv.
    let dir = tempfile::tempdir().unwrap();
    let mut labels = String::from("file,label,class,sources\n");
    for k in 0..7 {
        labels += &format!("reading/reading_{k:04}.csv,1,reading,a\n");
        if k < 5 {
            labels += &format!("conversation/conversation_{k:04}.csv,0,conversation,b\n");
        }
    }
    std::fs::write(dir.path().join("labels.csv"), labels).unwrap();
    for seed in [0u64, 1, 5, 1 << 40] {
        let jobs = list_sessions(dir.path(), seed).unwrap();
        let of = |class: &str| -> Vec<usize> {
            jobs.iter()
                .filter(|j| j.paths.file.starts_with(class))
                .map(|j| j.balanced_choice(seed, 3))
                .collect()
        };
        let (r, c) = (of("reading/"), of("conversation/"));
        // Positions within the class, in labels.csv order.
        let idx: Vec<usize> = jobs
            .iter()
            .filter(|j| j.paths.file.starts_with("reading/"))
            .map(|j| j.class_index)
            .collect();
        assert_eq!(idx, (0..7).collect::<Vec<_>>());
        // In turn from one start, the same in both classes: the
        // conversation sessions take what the first five reading ones take.
        let s = r[0];
        assert_eq!(r, (0..7).map(|k| (s + k) % 3).collect::<Vec<_>>());
        assert_eq!(c, r[..5].to_vec());
        // So each choice appears 2 or 3 times in reading and 1 or 2 in
        // conversation, never more than one apart within a class.
        for (v, n) in [(&r, 7), (&c, 5)] {
            let counts: Vec<usize> = (0..3)
                .map(|k| v.iter().filter(|&&x| x == k).count())
                .collect();
            assert_eq!(counts.iter().sum::<usize>(), n);
            assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 1);
        }
    }
    // The start moves with the dataset seed (over these seeds, more than one).
    let starts: std::collections::BTreeSet<usize> = (0..16u64)
        .map(|seed| list_sessions(dir.path(), seed).unwrap()[0].balanced_choice(seed, 3))
        .collect();
    assert!(starts.len() > 1);
}
