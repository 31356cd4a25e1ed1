//! k-d tree queries against brute force, and insertion-order independence.

use lwr::strategies::{inputs, linear_data, smooth_data};
use lwr::{Database, LwrModel, LwrSettings};
use proptest::prelude::*;

fn db_of(d: usize, xs: &[Vec<f64>]) -> Database {
    let mut db = Database::new(d, 1).expect("valid dims");
    for (i, x) in xs.iter().enumerate() {
        db.insert(x, &[i as f64]).expect("finite point");
    }
    db
}

fn scales_strategy(d: usize) -> impl Strategy<Value = Vec<f64>> {
    proptest::collection::vec(prop_oneof![Just(0.0), 0.1..3.0f64], d)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn radius_query_equals_brute_force(
        (xs, scales) in (1usize..5).prop_flat_map(|d| (inputs(d, 0..300, true), scales_strategy(d))),
        q0 in -1.2..1.2f64,
        radius in 0.0..1.5f64,
    ) {
        let db = db_of(scales.len(), &xs);
        let q = vec![q0; db.n_inputs()];
        let tree = db.within_radius(&q, &scales, radius).expect("valid query");
        let brute = db.within_radius_brute(&q, &scales, radius).expect("valid query");
        prop_assert_eq!(tree, brute);
    }

    #[test]
    fn knn_distances_equal_brute_force(
        (xs, scales) in (1usize..5).prop_flat_map(|d| (inputs(d, 0..300, true), scales_strategy(d))),
        q0 in -1.2..1.2f64,
        k in 0usize..20,
    ) {
        let db = db_of(scales.len(), &xs);
        let q = vec![q0; db.n_inputs()];
        let tree = db.nearest(&q, &scales, k).expect("valid query");
        let brute = db.nearest_brute(&q, &scales, k).expect("valid query");
        // ties may pick different points at the same distance
        let dt: Vec<f64> = tree.iter().map(|n| n.distance).collect();
        let db_: Vec<f64> = brute.iter().map(|n| n.distance).collect();
        prop_assert_eq!(dt, db_);
    }

    #[test]
    fn insertion_order_does_not_change_predictions(
        data in smooth_data(2, 2, 20..120, true, 0.05),
        seed in any::<u64>(),
    ) {
        let settings = LwrSettings { bandwidth: 0.4, ridge: 1e-6, ..Default::default() };
        let a = data.to_model(settings.clone()).expect("valid data");
        // a shuffled copy, inserted one by one
        let mut order: Vec<usize> = (0..data.inputs.len()).collect();
        let mut s = seed;
        for i in (1..order.len()).rev() {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            order.swap(i, (s >> 33) as usize % (i + 1));
        }
        let mut b = LwrModel::new(2, 2, settings).expect("valid settings");
        for &i in &order {
            b.insert(&data.inputs[i], &data.outputs[i]).expect("valid point");
        }
        for q in [[0.0, 0.0], [0.5, -0.3], [-0.7, 0.9]] {
            match (a.predict(&q), b.predict(&q)) {
                (Ok(pa), Ok(pb)) => {
                    for o in 0..2 {
                        let scale = 1.0 + pa.mean[o].abs();
                        prop_assert!((pa.mean[o] - pb.mean[o]).abs() < 1e-9 * scale);
                    }
                    prop_assert_eq!(pa.status, pb.status);
                    prop_assert_eq!(pa.n_neighbors, pb.n_neighbors);
                }
                (Err(ea), Err(eb)) => prop_assert_eq!(ea, eb),
                (ra, rb) => prop_assert!(false, "{:?} vs {:?}", ra, rb),
            }
        }
    }

    #[test]
    fn batch_equals_one_by_one(data in linear_data(3, 1, 10..80, true)) {
        let m = data.to_model(LwrSettings { bandwidth: 0.5, ..Default::default() }).expect("valid");
        let queries: Vec<Vec<f64>> = data.inputs.iter().take(10).cloned().collect();
        let batch = m.predict_batch(&queries);
        for (q, b) in queries.iter().zip(batch) {
            // NaN fields: compare the debug text
            prop_assert_eq!(format!("{:?}", m.predict(q)), format!("{:?}", b));
        }
    }
}

#[test]
fn sorted_and_clustered_inserts_keep_queries_exact() {
    let mut db = Database::new(2, 1).expect("valid");
    // a sweep along a line, then a dense cluster with many duplicates
    for i in 0..5000 {
        let t = i as f64 / 5000.0;
        db.insert(&[t, 2.0 * t], &[t]).expect("finite");
    }
    for i in 0..2000 {
        let v = (i % 7) as f64 * 1e-3;
        db.insert(&[0.5 + v, 0.5], &[v]).expect("finite");
    }
    assert!(db.tree_depth() < 60, "depth {}", db.tree_depth());
    for q in [[0.5, 0.5], [0.0, 0.0], [0.9, 1.7]] {
        for scales in [[1.0, 1.0], [0.0, 1.0], [3.0, 0.0]] {
            let t = db.within_radius(&q, &scales, 0.05).expect("valid");
            let b = db.within_radius_brute(&q, &scales, 0.05).expect("valid");
            assert_eq!(t, b);
        }
    }
}
