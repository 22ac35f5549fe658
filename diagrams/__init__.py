"""rpod.diagrams"""
