"""From the simulator to a rig: the rig protocol and its UDP transport, the envs' observation of a
rig's measurements, the safety supervisor, an exported policy under onnxruntime, the real-time
deploy loop and an emulated rig (docs/deploy.md). Nothing here imports torch; onnxruntime only
when an ONNX policy is loaded."""
