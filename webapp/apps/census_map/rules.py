"""The census map's names, shared by its app, actions, pages and routes."""

APP = "census"
CENSUS_SET = "census"
INDEX_TAG = "census:index"
