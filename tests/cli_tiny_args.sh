# The tiny model's training flags (without --data and --out) and its two
# configs, shared by the fixture (cli_tiny_model.sh), the training checks
# that rerun it (cli_infer_test.sh) and the SLURM jobs (slurm_test.sh), so
# all train the same model on the same 12 pairs.
TINY_TRAIN="--ngf 4 --ndf 4 --depth 5 --epochs 4 --epochs-decay 4"
# tiny_configs DIR -> DIR/ds.json (the dataset) and DIR/tr.json (the training)
tiny_configs() {
  cat > "$1/ds.json" <<'JSON'
{"count": 12, "size_px": 32, "levels": 3, "val_fraction": 0.2, "test_fraction": 0.2,
 "p_affine": 0.5, "p_translate": 0.5, "p_paste": 0.5, "paste_scale": 0.5}
JSON
  cat > "$1/tr.json" <<'JSON'
{"log_every": 5, "val_every": 20, "checkpoint_every": 1000, "val_samples": 2}
JSON
}
