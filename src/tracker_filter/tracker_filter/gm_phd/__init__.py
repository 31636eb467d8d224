"""The Gaussian-mixture PHD tracker (seed 004) with occlusion handling and labelling."""
