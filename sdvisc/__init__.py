"""The contract every package agrees on: the wire format, the vocabulary, the processes' configuration
models and the clock (plus shared helpers: issue 31 moves the processes up).
"""
