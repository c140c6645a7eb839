// qlv: being written
