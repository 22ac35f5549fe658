"""rpod.scenarios"""
