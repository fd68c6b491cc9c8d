"""Readers that turn external datasets into scene folders."""
