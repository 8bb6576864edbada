"""`moonbot bench`: the throughput benchmark (throughput.py) of the fixed config
configs/bench/throughput-v1.yaml at the quality levels of levels.py, against the limit of
limit.py (Embree and the encoders alone on the same work), and the comparison of result files
from different machines or runs (compare.py). The machine's fingerprint is fingerprint.py's."""
