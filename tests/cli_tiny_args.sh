# The tiny model's training flags (without --data and --out), shared by the
# fixture (cli_tiny_model.sh) and the training checks that rerun it
# (cli_infer_test.sh), so both train the same model.
TINY_TRAIN="--ngf 4 --ndf 4 --depth 5 --epochs 4 --epochs-decay 4"
