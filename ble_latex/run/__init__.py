# coding=utf-8
"""Running agents: training and evaluation loops, metrics, logs, suites, Ray."""
