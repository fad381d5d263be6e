"""Layer 2, the model: finite MDPs, partitions, their converters, generators and instance files."""
