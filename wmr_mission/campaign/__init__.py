"""Campaigns: one mission run many times with fields varied, judged by statistics."""
