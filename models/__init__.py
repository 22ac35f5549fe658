"""rpod.models"""
