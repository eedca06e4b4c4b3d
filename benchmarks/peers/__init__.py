"""The peer benchmark: this project side by side with Firmata (``make bench-peers``)."""
