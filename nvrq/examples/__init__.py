"""Runnable examples (nvrq layer): small inputs made from data the user has, never shipped as data."""
