# coding=utf-8
"""The paper's figures."""
