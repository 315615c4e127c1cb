"""Named scenes (STYLE 5.6 rule 7: one scene, three uses): ``tumble.scenes.contact`` builds the
contact benchmark scenes of /work/shared/BENCHMARKS.md; ``demo.toml`` is the demo's scene file."""
