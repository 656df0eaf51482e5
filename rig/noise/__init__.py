"""Noise of a sensor stream: Allan deviation and its noise terms, the spectrum, what a recording's statistics are."""
