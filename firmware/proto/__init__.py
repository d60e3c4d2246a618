"""The bench protocol's table and its generator (`python -m firmware.proto.gen_proto`)."""
