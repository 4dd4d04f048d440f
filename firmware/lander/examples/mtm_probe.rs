use lander::downlink::{KnapsackItem, MultipleKnapsack};
fn main() {
    let text = std::fs::read_to_string("firmware/lander/tests/mtm/instances.txt").unwrap();
    for (k, line) in text.lines().enumerate() {
        let f: Vec<Vec<u64>> = line
            .split_whitespace()
            .map(|x| {
                x.split('=')
                    .nth(1)
                    .unwrap()
                    .split(',')
                    .map(|n| n.parse().unwrap())
                    .collect()
            })
            .collect();
        let all = (1u16 << f[0].len()) - 1;
        let items: Vec<KnapsackItem> = f[1]
            .iter()
            .zip(&f[2])
            .map(|(&size, &value)| KnapsackItem {
                size,
                value,
                allowed: all,
            })
            .collect();
        let mut s = MultipleKnapsack::new();
        s.load(&items, &f[0]).unwrap();
        let mut budget = 0u64;
        while !s.step(1_000_000).done {
            budget += 1;
            if budget > 200 {
                break;
            }
        }
        println!(
            "{k}: n={} m={} nodes={} best={} opt={} done={}",
            items.len(),
            f[0].len(),
            s.nodes(),
            s.best_value(),
            f[3][0],
            s.proven_optimal()
        );
    }
}
