"""Benchmarks: speed and memory as ratios against in-process baselines (make bench)."""
